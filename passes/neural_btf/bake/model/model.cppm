// weft.btf.model — a trained neural BTF: the decoder MLP (latent + two stereographic
// directions -> RGB), the latents (one per texel, or one per cluster with a cluster id per
// texel), optional per-texel scales, and the constants that undo preprocessing. decode() is
// the CPU reference the NeuralBTFMaterial shader is tested against.
module;
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.btf.model;
import weft.core;

export namespace weft::btf {

// Stereographic projection of a tangent-frame direction (z = normal), the decoder's
// direction input: R = sin(π−θ) / (1 − cos(π−θ)) = tan(θ/2), (x, y) = R (cos φ, sin φ).
// Written as (dx, dy) / (1 + dz), which is exact and finite for every dz > −1 (θ = 0 gives
// (0, 0), θ = 90° gives the unit circle). `direction` need not be normalised.
[[nodiscard]] vec2 stereographic(const vec3& direction);

// A fully connected layer: out = W in + b, W row-major (outputs × inputs).
struct DenseLayer {
  std::uint32_t inputs = 0, outputs = 0;
  std::vector<float> weights;  // outputs * inputs
  std::vector<float> bias;     // outputs
};

// The decoder: 12 -> 106 -> 106 -> 106 -> 3 in the paper, ReLU after every layer but the
// last. Input order: latent[0..L), stereographic(ω_i).xy, stereographic(ω_o).xy.
struct Decoder {
  std::vector<DenseLayer> layers;
  [[nodiscard]] std::uint32_t input_size() const { return layers.empty() ? 0 : layers.front().inputs; }
  [[nodiscard]] std::size_t parameter_count() const;
};

struct NeuralBtf {
  std::uint32_t width = 0, height = 0;  // texels
  std::uint32_t latent_size = 8;
  Decoder decoder;
  std::vector<float> latents;              // latent_count() * latent_size
  std::vector<std::uint32_t> cluster_ids;  // per texel; empty: texel i uses latent i
  std::vector<float> texel_scales;         // per texel; empty: all 1 (the paper's blotch fix)
  float output_scale = 1.0f;               // the training targets' global max (targets = rgb / max)

  [[nodiscard]] std::size_t texels() const { return std::size_t(width) * height; }
  [[nodiscard]] std::size_t latent_count() const { return latent_size ? latents.size() / latent_size : 0; }
  [[nodiscard]] bool clustered() const { return !cluster_ids.empty(); }
  [[nodiscard]] std::span<const float> latent_of_texel(std::size_t texel) const;
};

// Linear RGB reflectance of one texel for light ω_i and view ω_o (tangent frame):
// max(0, decoder(latent, stereo(ω_i), stereo(ω_o))) * output_scale * texel_scale.
[[nodiscard]] vec3 decode(const NeuralBtf& model, std::size_t texel, const vec3& light, const vec3& view);
// The decoder alone, for an explicit input vector (size decoder.input_size()).
[[nodiscard]] vec3 evaluate(const Decoder& decoder, std::span<const float> input);

// A model with random weights (He-uniform, biases small), latents in [-1, 1], optional
// cluster ids and scales: for tests, benchmarks and the shader's agreement with decode().
struct RandomModelOptions {
  std::uint32_t width = 4, height = 4;
  std::uint32_t latent_size = 8;
  std::vector<std::uint32_t> hidden{106, 106, 106};  // the paper's decoder
  std::uint32_t clusters = 0;  // 0: one latent per texel
  bool scales = false;         // per-texel scales in [0.5, 1.5]
  float output_scale = 1.0f;
  std::uint64_t seed = 1;
};
[[nodiscard]] NeuralBtf random_model(const RandomModelOptions& options);

// Whether a model can be decoded: the layers chain (latent_size + 4 -> ... -> 3), the
// latents hold latent_count() whole latents (one per texel unless clustered), every
// cluster id names a latent, scales are one per texel, and every number is finite.
// InvalidArgument naming the part that is wrong.
Result<void> validate(const NeuralBtf& model);

// Bytes a texel grid costs in a model, independent of the file's framing: the numbers
// the issue's compression ratios count (decoder weights, latents, ids, scales).
struct ModelBytes {
  std::size_t decoder = 0, latents = 0, ids = 0, scales = 0;
  [[nodiscard]] std::size_t total() const { return decoder + latents + ids + scales; }
};

// ---- the .wbtf file ---------------------------------------------------------------------
//
// Little-endian. A 72-byte header: magic "WEFTNBTF", version, header size, width, height,
// latent size, latent count, layer count, flags (1 clustered, 2 per-texel scales), the four
// storage formats, the output scale, the section count and an FNV-1a checksum of the rest
// of the header. Then four sections, each tag, reserved, u64 size, u64 checksum, payload:
//   "MLP"  per layer: inputs, outputs (u32), weights (outputs x inputs), bias (outputs)
//   "LAT"  latent_count x latent_size values
//   "IDS"  one cluster id per texel (empty unless clustered)
//   "SCL"  one scale per texel (empty without scales); 8-bit: f32 min, f32 max, then bytes
// Every size is checked against the header and the file before it is used.

inline constexpr std::uint32_t kWbtfVersion = 1;

enum class FloatStorage : std::uint8_t { Fp32, Fp16 };
enum class IdStorage : std::uint8_t { Auto, U8, U16, U32 };  // Auto: the smallest that holds k - 1
enum class ScaleStorage : std::uint8_t { Fp32, Fp16, U8 };  // U8: linear between the min and max
std::string_view to_string(FloatStorage s);
std::string_view to_string(IdStorage s);
std::string_view to_string(ScaleStorage s);

struct WbtfOptions {
  FloatStorage weights = FloatStorage::Fp32;
  FloatStorage latents = FloatStorage::Fp32;
  IdStorage ids = IdStorage::Auto;
  ScaleStorage scales = ScaleStorage::Fp32;
};
// The paper-style stretch setting: fp16 weights and latents, 8-bit ids (k <= 256) and scales.
inline constexpr WbtfOptions kCompactWbtf{FloatStorage::Fp16, FloatStorage::Fp16, IdStorage::Auto, ScaleStorage::U8};

// What a model costs stored with `options` (payloads only; the file adds 72 + 4 x 24 bytes
// of header and section framing and 8 bytes per layer of shapes).
[[nodiscard]] ModelBytes model_bytes(const NeuralBtf& model, const WbtfOptions& options = {});

// The file's bytes, and back. encode fails (InvalidArgument) on an invalid model, on ids that
// do not fit the requested width and on values fp16 cannot hold. decode names `source` and
// the section in every error.
Result<std::vector<std::byte>> encode_wbtf(const NeuralBtf& model, const WbtfOptions& options = {});
Result<NeuralBtf> decode_wbtf(std::span<const std::byte> bytes, std::string_view source);

Result<void> save_wbtf(const NeuralBtf& model, const std::filesystem::path& path, const WbtfOptions& options = {});
Result<NeuralBtf> load_wbtf(const std::filesystem::path& path);

}  // namespace weft::btf
