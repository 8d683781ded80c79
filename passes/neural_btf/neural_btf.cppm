// weft.pass.neural_btf — NeuralBTFMaterial: a neural BTF (weft.btf.model, a .wbtf file)
// decoded per fragment. The decoder MLP runs in the fragment shader with every weight, latent,
// cluster id and scale in one read-only storage buffer; ω_i (the key light, and optionally
// ω_i = n for the ambient term) and ω_o go into the surface's tangent frame. The reference
// mode samples the raw BTF (in a storage buffer, as weft::btf::sample_reference) in the same
// fragment stage, so the two images compare pixel for pixel. Also here: the
// decode kernel (a compute shader with the same decoder) that tests compare with the CPU
// decode and the benchmark times, and the feature descriptor (neural_btf_feature).
// docs/neural-btf.md, "The material and its shader", has the choices and the measurements.
//
// Two paths decode the same model with the same inputs (material field "decoder"):
//  - batched (the default): the geometry pass writes each visible pixel's decode inputs into a
//    G-buffer, a compute pass decodes them per 16 x 16 screen tile as batched matrix products
//    (btf_decode_tiled.glsl: weights at uniform addresses reused across a batch of 64 rows,
//    blocks of 8 outputs per row in registers) and a resolve writes the radiance into the scene
//    colour. No overdraw is decoded; the showcase's cushion costs 4 - 6x less frame time
//    than through the fragment path on lavapipe.
//  - fragment: the decoder in the fragment shader (overdraw decodes too). Debug views use it.
// docs/neural-btf.md, "The batched decode", has the measurements.
module;
#include <functional>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
namespace CLI {
class App;  // what a bake command adds its options to
}
export module weft.pass.neural_btf;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;
import weft.feature;
import weft.btf;
import weft.btf.model;

export namespace weft::btf {

enum class BtfMode : std::uint8_t { Neural, Reference };
enum class TexelFilter : std::uint8_t { Nearest, Bilinear };
enum class BtfDebugView : std::uint8_t { None, Texel, Uv, Frame };
enum class BtfDecoder : std::uint8_t { Batched, Fragment };
std::string_view to_string(BtfMode m);
std::string_view to_string(TexelFilter f);
std::string_view to_string(BtfDebugView d);
std::string_view to_string(BtfDecoder d);

// A "neural_btf" material's fields (docs/neural-btf.md lists them with their JSON names).
struct NeuralBtfParams {
  std::filesystem::path model;  // .wbtf, relative to the scene file
  vec2 uv_scale{1.0f};          // how many times the texel grid repeats over the mesh's UVs
  BtfMode mode = BtfMode::Neural;
  std::filesystem::path btf;    // the raw BTF the reference mode samples (.btfraw or a database folder)
  // "btf": "synthetic:<weave>:<W>x<H>[:<seed>]" names weft's synthetic fabric (synthetic_btf
  // with that weave, size and seed, the rest default) instead of a file: what `weft bake btf
  // --synthetic` trained on, so a baked model can be compared with its own data.
  struct Synthetic {
    std::string weave = "twill";
    std::uint32_t width = 0, height = 0;
    std::uint64_t seed = 1;
  };
  std::optional<Synthetic> btf_synthetic;
  float exposure = 1.0f;        // multiplies the result
  vec3 tint{1.0f};              // multiplies the result per channel
  // Quality knobs (each costs decodes per pixel; the presets set them unless the material does):
  bool ambient = true;          // one more decode (ω_i = n) times the environment's SH irradiance
  TexelFilter filter = TexelFilter::Nearest;  // bilinear: 4 decodes per light, blended
  bool shadow = true;           // the key light's shadow map (3x3 PCF)
  BtfDebugView debug_view = BtfDebugView::None;
  // Batched: G-buffer + tiled compute decode + resolve; fragment: the decoder per fragment.
  // Debug views always draw through the fragment path.
  BtfDecoder decoder = BtfDecoder::Batched;
};

// What a quality preset sets when the material does not: low = no ambient decode, nearest;
// medium = ambient, nearest; high and reference = ambient, bilinear.
struct NeuralBtfQualityPreset {
  bool ambient = true;
  TexelFilter filter = TexelFilter::Nearest;
};
NeuralBtfQualityPreset neural_btf_quality_preset(Quality quality);
// Reads a scene material's params with JsonReader: every problem in one Parse error, each at
// its JSON path; `quality` sets the knobs it leaves out (neural_btf_quality_preset).
Result<NeuralBtfParams> parse_neural_btf_material(const scene::Material& material, Quality quality = Quality::Medium);

}  // namespace weft::btf

export namespace weft::passes {

// The shader's limits (btf_decode.glsl): layers and the widest layer (or latent + 4).
inline constexpr std::uint32_t kBtfMaxLayers = 8;
inline constexpr std::uint32_t kBtfMaxWidth = 128;

// The model as the shader reads it (one std430 buffer; see btf_decode.glsl): 32-bit words.
// InvalidArgument when the model is invalid, Unsupported when it exceeds the shader's limits.
Result<std::vector<std::uint32_t>> pack_model(const btf::NeuralBtf& model);

// The paper's decoder shape (latent 8; 12 -> 106 -> 106 -> 106 -> 3), which the decode
// kernel also has compiled in with the inner loops unrolled (BTF_PAPER_SHAPE in
// btf_decode.glsl), for comparison. On lavapipe that variant measured SLOWER than the generic
// one, which loops over the shape (kernel 1.6 against 2.3 GFLOP/s; as a fragment shader 3.0
// against 5.0, weft-bench-btf-decode, docs/neural-btf.md), so the material's fragment shader
// is the generic one only; the kernel keeps both for a real GPU's compiler to be measured.
[[nodiscard]] bool is_paper_shape(const btf::NeuralBtf& model);

// A model on the GPU and which shader variant decodes it.
struct GpuBtfModel {
  gpu::Buffer buffer;
  bool paper_shape = false;  // the decode kernel uses its unrolled variant
  bool tiled = false;        // the paper's shape: the batched decoder (btf_decode_tiled.glsl) takes it
};
// `allow_unrolled` = true: the decode kernel decodes a paper-shaped model with the unrolled
// variant (materials always use the generic one).
Result<GpuBtfModel> upload_model(gpu::Device& device, const btf::NeuralBtf& model, std::string_view label,
                                 bool allow_unrolled = false);

// The reference mode's data (btf_reference.glsl): the raw BTF's directions and samples in one
// std430 buffer of 32-bit words. A BTF larger than `max_bytes` is cropped to its top-left
// texels, keeping the aspect ratio (the largest crop that fits); `crop` says which texels.
// InvalidArgument for an invalid BTF, Unsupported when not even one texel fits.
struct PackedBtfReference {
  std::vector<std::uint32_t> words;
  btf::Crop crop;  // width, height: the texel grid the shader tiles
  bool cropped = false;
};
Result<PackedBtfReference> pack_reference(const btf::Btf& btf, std::uint64_t max_bytes);

// The raw BTF on the GPU (pack_reference with the device's storage-buffer range, at most 1 GiB).
struct GpuBtfReference {
  gpu::Buffer buffer;
  btf::Crop crop;
  bool cropped = false;
};
Result<GpuBtfReference> upload_reference(gpu::Device& device, const btf::Btf& btf, std::string_view label);

// One decode query: ω_i and ω_o in the tangent frame (need not be normalised) and a texel.
struct DecodeQuery {
  vec3 light;
  float texel = 0.0f;  // the texel index as a float (exact below 2^24)
  vec3 view;
  float pad = 0.0f;
};
static_assert(sizeof(DecodeQuery) == 32);

// Which shader of the decode kernel: Auto = the unrolled one when upload_model allowed it,
// else the generic one (one query per invocation, btf_decode.glsl); Tiled = the batched
// decoder of the material's batched path (btf_decode_tiled.glsl; paper-shaped models only).
enum class DecodeVariant : std::uint8_t { Auto, Generic, Unrolled, Tiled };
std::string_view to_string(DecodeVariant v);

// The decoder as a compute kernel over a buffer of queries (btf_decode.comp,
// btf_decode_tiled.comp): the shader code of the material, without the rasteriser. For tests
// and the throughput benchmark.
class BtfDecodeKernel {
 public:
  static Result<BtfDecodeKernel> create(gpu::Device& device);
  // Uploads the queries, decodes, reads back one RGBA per query (A = 1).
  Result<std::vector<vec4>> decode(gpu::Device& device, const GpuBtfModel& model, std::span<const DecodeQuery> queries,
                                   DecodeVariant variant = DecodeVariant::Auto) const;
  // For timing: decodes `count` queries already in `queries` into `results` (Storage buffers),
  // submits and waits. Returns the wall-clock seconds of submit + wait. Unsupported when the
  // variant cannot decode the model's shape.
  Result<double> run(gpu::Device& device, const GpuBtfModel& model, const gpu::Buffer& queries, const gpu::Buffer& results,
                     std::uint32_t count, DecodeVariant variant = DecodeVariant::Auto) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// One object the pass draws.
struct NeuralBtfDraw {
  const frame::GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  std::uint32_t material = 0;  // index into the materials given to NeuralBTFMaterial::add
};

// A material on the GPU: its parameters, its model buffer and their bind group.
struct NeuralBtfGpuMaterial;

// The graph passes: draw neural BTF objects into "scene_color"/"scene_depth" (loading what
// the forward pass drew), reading "frame_uniforms" and "shadow_map". Batched materials: the
// passes neural_btf (geometry into the G-buffer), neural_btf_decode (compute),
// neural_btf_composite (the objects again, into the scene colour and depth); fragment-path
// materials: neural_btf_fragment.
class NeuralBTFMaterial {
 public:
  static Result<NeuralBTFMaterial> create(gpu::Device& device);
  // `model` (from upload_model) must outlive the material.
  Result<std::shared_ptr<NeuralBtfGpuMaterial>> create_material(gpu::Device& device, const btf::NeuralBtfParams& params,
                                                                const GpuBtfModel& model) const;
  // The reference mode: the raw BTF (from upload_reference, which must outlive the material)
  // sampled where the neural mode decodes, by the same fragment stage otherwise.
  Result<std::shared_ptr<NeuralBtfGpuMaterial>> create_material(gpu::Device& device, const btf::NeuralBtfParams& params,
                                                                const GpuBtfReference& reference) const;
  // `draws` and `materials` must outlive the graph's execution; the materials' model buffers
  // are imported and declared as storage reads.
  // `width` x `height`: the frame; `view_projection`: the frame's camera (with its jitter), by
  // which the batched path sizes its G-buffer and lists to the pixels its objects can cover.
  Result<void> add(RenderGraph& graph, std::span<const NeuralBtfDraw> draws,
                   std::span<const std::shared_ptr<NeuralBtfGpuMaterial>> materials, std::uint32_t width,
                   std::uint32_t height, const mat4& view_projection) const;

 private:
  Result<void> add_batched(RenderGraph& graph, std::vector<NeuralBtfDraw> draws,
                           std::span<const std::shared_ptr<NeuralBtfGpuMaterial>> materials, std::uint32_t width,
                           std::uint32_t height, const mat4& view_projection) const;
  struct State;
  std::shared_ptr<State> state_;
};

// The feature: material type "neural_btf" (alias "btf", its old --feature name), its knob
// table, its FeaturePass. Models are loaded once per file (path and modification time).
const FeatureDescriptor& neural_btf_feature();

}  // namespace weft::passes

// The feature's `weft bake btf` command (its descriptor's `bakes`); not exported.
namespace weft::passes::detail {
std::function<int()> add_btf_bake(CLI::App& command);
}  // namespace weft::passes::detail
