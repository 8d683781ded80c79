// weft.btf.model — a trained neural BTF: the decoder MLP (latent + two stereographic
// directions -> RGB), the latents (one per texel, or one per cluster with a cluster id per
// texel), optional per-texel scales, and the constants that undo preprocessing. decode() is
// the CPU reference the NeuralBTFMaterial shader is tested against.
module;
#include <cstddef>
#include <cstdint>
#include <span>
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

}  // namespace weft::btf
