// weft.frame — what every pass of a frame shares without knowing the scene file: meshes on
// the GPU in weft's one vertex layout, the per-frame uniforms (camera, key light, shadow
// matrix, environment), the frame's shared targets (one typed blackboard entry), the one
// helper that draws lit meshes into the scene colour, and the pipeline and shadow sampler
// that the passes drawing lit meshes all create alike.
module;
#include <map>
#include <utility>
#include <array>
#include <cstdint>
#include <memory>
#include <expected>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.frame;
import weft.core;
import weft.gpu;
import weft.graph;

export namespace weft::frame {

// One interleaved vertex for every pass (64 bytes; matches shaders/frame.glsl).
struct Vertex {
  vec3 position;
  float curvature = 0.0f;  // |Δn|/|Δp| per vertex, 1/mm-free units of the mesh (skin uses it)
  vec3 normal;
  float pad0 = 0.0f;
  vec4 tangent{1, 0, 0, 1};  // xyz tangent, w handedness
  vec2 uv{0, 0};
  vec2 uv1{0, 0};  // the second UV set (glTF's TEXCOORD_1); a copy of uv when the mesh has none
};
static_assert(sizeof(Vertex) == 64);

// The vertex buffer layout of frame::Vertex, locations 0..4. uv1 has no location here: the
// forward pass adds location 5 for it (a layout attribute no shader reads is a warning).
gpu::VertexBufferLayout vertex_layout();

// The pipeline the passes that shade meshes into the scene's colour and depth share
// (forward, skin, fur, SSDF, neural BTF): one vertex buffer (frame::Vertex unless told
// otherwise), triangles, both faces drawn, one colour target, depth tested (less) and written.
Result<gpu::RenderPipeline> create_lit_mesh_pipeline(gpu::Device& device, std::string label,
                                                     const gpu::PipelineLayout& layout, const gpu::ShaderModule& vertex,
                                                     const gpu::ShaderModule& fragment, gpu::Format color_format,
                                                     gpu::Format depth_format,
                                                     gpu::VertexBufferLayout vertices = vertex_layout());

// ---- multisampling ------------------------------------------------------------------------

// A render pipeline in each sample count the frames that use it draw with (1 without MSAA).
// The descriptor and its shaders are kept; the 1-sample pipeline is made at once (so its
// errors come at creation), the others the first time a frame asks. The passes that draw
// into the scene colour hold theirs in one and bind at(device, ScenePassDraw::samples).
// Copies share one set of pipelines; at() is thread-safe.
class PipelineSamples {
 public:
  // `desc.layout`, `desc.vertex` and `desc.fragment` are set to the kept layout and modules
  // (the pipelines of other counts are made later, from them). With alpha_to_coverage the
  // multisampled pipelines turn the fragment's alpha into coverage (the 1-sample one cannot:
  // its shader must test alpha itself).
  static Result<PipelineSamples> create(gpu::Device& device, std::shared_ptr<const gpu::PipelineLayout> layout,
                                        gpu::RenderPipelineDescriptor desc,
                                        gpu::ShaderModule vertex, std::optional<gpu::ShaderModule> fragment,
                                        bool alpha_to_coverage = false);
  // The pipeline for attachments of `samples` samples.
  Result<const gpu::RenderPipeline*> at(gpu::Device& device, std::uint32_t samples) const;
  [[nodiscard]] const gpu::RenderPipeline& single_sample() const;
  [[nodiscard]] bool alpha_to_coverage() const;
  // The fragment shader of the pipelines of more than one sample from now on (a variant that
  // runs per sample: shell fur's hair test); call it before the first at(device, n > 1).
  void set_multisample_fragment(gpu::ShaderModule fragment);

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// What create_lit_mesh_pipeline makes, as a descriptor without shaders.
gpu::RenderPipelineDescriptor lit_mesh_pipeline_descriptor(std::string label, const gpu::PipelineLayout& layout,
                                                           gpu::Format color_format, gpu::Format depth_format,
                                                           gpu::VertexBufferLayout vertices = vertex_layout());
// The lit-mesh pipeline in every sample count (into the scene colour and depth formats).
Result<PipelineSamples> create_lit_mesh_pipelines(gpu::Device& device, std::string label,
                                                  std::shared_ptr<const gpu::PipelineLayout> layout,
                                                  gpu::ShaderModule vertex,
                                                  gpu::ShaderModule fragment,
                                                  gpu::VertexBufferLayout vertices = vertex_layout(),
                                                  bool alpha_to_coverage = false);

// The sampler a lit pass reads the shadow map through (sampler2DShadow): a less-or-equal
// depth comparison, linearly filtered, level 0 only.
Result<gpu::Sampler> create_shadow_compare_sampler(gpu::Device& device, std::string label);

struct GpuMesh {
  std::string name;
  gpu::Buffer vertices;
  gpu::Buffer indices;
  std::uint32_t index_count = 0;
  std::uint32_t vertex_count = 0;
  vec3 bounds_min{0}, bounds_max{0};
};

struct MeshData {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
};
Result<GpuMesh> upload_mesh(gpu::Device& device, const MeshData& mesh);

struct StandardMaterial {
  vec3 base_color{0.8f};
  float metallic = 0.0f;
  float roughness = 0.5f;
  vec3 emissive{0.0f};
  float normal_scale = 1.0f;
  float occlusion_strength = 1.0f;
};

// One map of a standard material: the view, its sampler and the UV set it reads. A null
// view means none (the pass binds its neutral texture).
struct MaterialMap {
  const gpu::TextureView* view = nullptr;
  const gpu::Sampler* sampler = nullptr;  // null: linear, repeat
  std::uint32_t texcoord = 0;             // 0: uv, 1: uv1
};

// One mesh for the forward pass (standard materials); features keep their own draw lists.
struct DrawItem {
  const GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  StandardMaterial material;
  const gpu::TextureView* base_color_texture = nullptr;  // sRGB, multiplies base_color; null = white
  // The other maps of a standard material (glTF's metallic-roughness model); base_color's
  // sampler and UV set are maps[0]'s. 0 base colour (sRGB; view = base_color_texture),
  // 1 metallic-roughness (G roughness, B metallic), 2 normal (tangent space), 3 occlusion (R),
  // 4 emissive (sRGB).
  std::array<MaterialMap, 5> maps{};
};

// Lights beyond the key light (the first directional one, which casts the shadow map),
// shaded by the standard material without shadows. Units as weft::scene's lights.
inline constexpr std::uint32_t max_punctual_lights = 8;
struct PunctualLight {
  vec4 position_range{0.0f};    // xyz position, w range (0 = infinite)
  vec4 direction_type{0.0f};    // xyz unit direction the light travels, w: 0 point, 1 spot, 2 directional
  vec4 color{0.0f};             // rgb * intensity
  vec4 cone{0.0f, 1.0f, 0.0f, 0.0f};  // spot: x = 1 / max(cos inner - cos outer, 1e-4), y = -cos outer * x
};

// std140 per-frame uniforms, bound as set 0 binding 0 by the passes that need them.
struct FrameUniforms {
  mat4 view{1.0f};
  mat4 projection{1.0f};
  mat4 view_projection{1.0f};
  mat4 inverse_view_projection{1.0f};
  mat4 light_view_projection{1.0f};
  vec4 camera_position{0, 0, 0, 1};
  vec4 light_direction{0, 1, 0, 0};  // xyz: unit vector towards the key light
  vec4 light_color{1, 1, 1, 0};      // rgb * intensity (radiance at normal incidence)
  vec4 environment{1, 0, 0, 0};      // x intensity, y rotation (radians), z has map (0/1)
  vec4 viewport{1, 1, 1, 1};         // width, height, 1/width, 1/height
  std::array<vec4, 9> irradiance_sh{};  // order-2 SH of the environment's irradiance (rgb)
  vec4 light_count{0.0f};               // x: how many of `lights` are used
  std::array<PunctualLight, max_punctual_lights> lights{};
};
static_assert(sizeof(FrameUniforms) % 16 == 0);

// The sub-pixel offset of sample `index` of a temporally accumulated view, in pixels within
// [-0.5, 0.5): none for sample 0 (the pixel centre: the frame without accumulation), then the
// points of the Halton (2, 3) sequence -- low discrepancy, so every prefix covers the pixel
// evenly and N samples converge towards an N-sample box-filtered supersampling.
vec2 sample_jitter(std::uint32_t index);
// `projection` moved by `jitter` pixels (x right, y down in the image) on a width x height
// target, in clip space, so every pass that draws with the matrix moves with it.
mat4 jitter_projection(const mat4& projection, vec2 jitter, std::uint32_t width, std::uint32_t height);

// Order-2 spherical harmonics of the cosine-convolved radiance of an equirectangular map
// (Ramamoorthi & Hanrahan 2001): E(n) = sum c_i Y_i(n). `rgb` is width*height*3 floats.
std::array<vec4, 9> irradiance_sh(std::span<const float> rgb, std::uint32_t width, std::uint32_t height,
                                  float rotation_radians = 0.0f);
vec3 evaluate_sh(const std::array<vec4, 9>& sh, vec3 normal);
// Exact SH of a constant sky of radiance c: E(n) = π c everywhere.
std::array<vec4, 9> constant_irradiance_sh(vec3 radiance);

// ---- the frame's shared targets --------------------------------------------------------

// The formats of the scene colour (HDR, linear) and depth the lit passes draw into.
inline constexpr gpu::Format scene_color_format = gpu::Format::RGBA16Float;
inline constexpr gpu::Format scene_depth_format = gpu::Format::Depth32Float;

// What the passes of one frame share, as one typed blackboard entry (Filament's blackboard
// of well-known handles): the renderer puts the uniforms, the environment and the shadow
// map; the forward pass creates the colour and depth; every lit pass after it loads them
// and puts back the versions it wrote. The blackboard keys behind it live in frame.cpp only.
struct SceneTargets {
  BufferHandle uniforms;      // FrameUniforms (set 0, binding 0 of the lit passes)
  TextureHandle environment;  // equirectangular RGBA32F radiance
  TextureHandle shadow_map;   // the key light's depth; a 1x1 far depth without a key light
  TextureHandle color;        // scene_color_format
  TextureHandle depth;        // scene_depth_format
};
// Which targets a pass cannot do without; the others may be absent (invalid handles then):
// the colour and depth for the pass that creates them, the environment for passes that do
// not sample it.
struct SceneTargetNeeds {
  bool uniforms = true, environment = true, shadow_map = true, color = true, depth = true;
};
// The handles on the blackboard; the first needed one missing is an error naming it (and
// the pass asking, inside a setup).
Result<SceneTargets> scene_targets(const Blackboard& board, SceneTargetNeeds needs = {});
// Puts every valid handle of `targets`; invalid ones leave the blackboard's entry as it is.
void put_scene_targets(Blackboard& board, const SceneTargets& targets);

// ---- drawing lit meshes into the scene colour ------------------------------------------------

// A persistent asset a lit pass reads: imported into the graph once per frame however many
// draws use it (by address), under `label`, then read sampled (textures) or as read-only
// storage (buffers). Null pointers are skipped.
struct PassTexture {
  std::string label;
  const gpu::Texture* texture = nullptr;
};
struct PassBuffer {
  std::string label;
  const gpu::Buffer* buffer = nullptr;
};

struct ScenePassDesc {
  std::string name;                  // the graph pass and its render pass label
  bool reads_environment = false;    // also sample the environment (the shadow map always)
  std::vector<PassTexture> textures;
  std::vector<PassBuffer> buffers;
  // The first lit pass of a frame (forward): creates the scene colour and depth, cleared to
  // this colour and the far plane, instead of loading the blackboard's.
  std::optional<vec4> clear_color;
  // With clear_color: the sample count of the colour and depth it creates (MSAA); the later
  // lit passes draw with the count of what they load.
  std::uint32_t samples = 1;
};

// What the draw callback gets: the render pass already begun on the scene colour and depth
// (ended after the callback), the frame's shared inputs, and the pass context (device,
// keep(), errors). A callback that fails reports the error on context.encoder() and returns.
struct ScenePassDraw {
  gpu::RenderPassEncoder& pass;
  PassContext& context;
  const gpu::Buffer& uniforms;
  const gpu::TextureView& shadow_map;
  const gpu::TextureView* environment = nullptr;  // when reads_environment
  std::uint32_t samples = 1;  // the colour and depth's sample count: bind pipelines made for it
};
using DrawScene = std::function<void(ScenePassDraw& draw)>;

// Filament's colorPass: finds the frame's SceneTargets, declares the reads (uniforms, shadow
// map, environment, the imported assets) and the colour and depth attachments, records
// `draw` inside one render pass, and puts the new colour and depth versions back. A lit
// pass keeps only its pipeline and draw loop. Errors: a missing shared target.
Result<void> add_scene_color_pass(RenderGraph& graph, ScenePassDesc desc, DrawScene draw);

// The sample count of the scene colour on the blackboard (1 when there is none yet).
std::uint32_t scene_sample_count(const RenderGraph& graph);

// A single-sample copy of a multisampled texture in a new transient `name` of its format and
// size (colour: the average of the samples, a transfer; depth: `depth_mode`, a render pass
// with `source` read-only). `source` is only read, so several passes may resolve one version
// while others still draw into it. Returns the resolved handle. weft.pipeline's runner inserts
// one where a multisampled output feeds an input that reads texels.
Result<TextureHandle> add_resolve_pass(RenderGraph& graph, std::string name, TextureHandle source,
                                       gpu::ResolveMode depth_mode = gpu::ResolveMode::SampleZero);

// SPIR-V of shaders/fullscreen.vert: one triangle over the screen at the far plane, `uv` out.
std::span<const std::uint32_t> fullscreen_vertex_spirv();

// A full-screen pass's GPU objects: the triangle of fullscreen.vert, a fragment shader that
// samples `textures` textures at bindings 0..textures-1 of set 0 (then the frame uniforms at
// binding `textures` when `uniforms`), push constants of `push_size` bytes, one colour target.
// Post-processing and debug passes (bloom, outline, debug views, users' passes) share it.
struct FullscreenPipeline {
  gpu::BindGroupLayout bind_layout;
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
  std::uint32_t textures = 0;
  bool uniforms = false;
};
Result<FullscreenPipeline> create_fullscreen_pipeline(gpu::Device& device, std::string label,
                                                      std::span<const std::uint32_t> fragment_spirv,
                                                      std::uint32_t textures, bool uniforms, std::uint32_t push_size,
                                                      gpu::Format target);
// Records one full-screen draw into `target` (its previous contents discarded): a bind group
// of `textures` (each through `sampler`) and `uniforms`, kept until the frame is done.
// Failures are reported on the encoder.
void draw_fullscreen(PassContext& context, const FullscreenPipeline& pipeline, std::string_view label,
                     const gpu::TextureView& target, std::span<const gpu::TextureView* const> textures,
                     const gpu::Sampler& sampler, const gpu::Buffer* uniforms, std::span<const std::byte> push);

// A pipeline pass type's one full-screen draw, declared: reads `inputs` (sampled, bound at
// 0..n-1 in order, then the frame uniforms from the blackboard), writes `target` -- or a new
// transient "<name>.color" of `format` at the frame's size when it is invalid -- and draws
// `pipeline` there with `push`. Returns the target's new version. The debug views and the
// outline are this; a pass with a chain of draws (bloom) declares its own.
struct FullscreenPass {
  std::string name;                   // the graph pass
  std::vector<TextureHandle> inputs;  // at most 4
  TextureHandle target;
  gpu::Format format = gpu::Format::RGBA8Unorm;
  std::vector<std::byte> push;        // push constants
};
// `pipeline` and `sampler` must live until the frame has executed: `owner`, what holds them,
// is kept by the pass's callback until then.
Result<TextureHandle> add_fullscreen_pass(RenderGraph& graph, FullscreenPass pass, const FullscreenPipeline& pipeline,
                                          const gpu::Sampler& sampler, std::shared_ptr<const void> owner);

// A full-screen effect on the frame's colour in whichever format it comes (the tone-mapped
// rgba8unorm or the linear rgba16float): a FullscreenPipeline per format and the sampler its
// inputs are read through, made once. The outline and FXAA pass types are this.
class ColorEffect {
 public:
  static Result<ColorEffect> create(gpu::Device& device, std::string label, std::span<const std::uint32_t> fragment_spirv,
                                    std::uint32_t textures, bool uniforms, std::uint32_t push_size,
                                    gpu::SamplerDescriptor sampler);
  // The effect drawn by pass `name` from `inputs` (inputs[0] the colour, whose format the
  // result takes) into `target`, or into a new texture when it is invalid. An Unsupported
  // error naming the pass when the colour is in neither format.
  Result<TextureHandle> add(RenderGraph& graph, std::string_view name, std::vector<TextureHandle> inputs,
                            TextureHandle target, std::span<const std::byte> push) const;

 private:
  struct State;
  std::shared_ptr<const State> state_;
};

// A temporal pass's GPU objects (accumulate, taa): `blend` draws this frame into the history
// (rgba16float; `blend_textures` inputs, `push_size` bytes of the pass's push constants),
// `output` per colour format (rgba8unorm, rgba16float) writes the history back in the input's
// encoding (shaders/temporal_output.frag, the same for every temporal pass), `sampler`
// bilinear and clamped.
struct TemporalPipelines {
  FullscreenPipeline blend;
  std::map<gpu::Format, FullscreenPipeline> output;
  gpu::Sampler sampler;
  static Result<std::shared_ptr<const TemporalPipelines>> create(gpu::Device& device, const std::string& label,
                                                                 std::span<const std::uint32_t> blend_spirv,
                                                                 std::uint32_t blend_textures, std::uint32_t push_size);
  // Whether `format` is one `output` writes.
  [[nodiscard]] bool writes(gpu::Format format) const { return output.contains(format); }
  // Pass `name`: `history` (what blend wrote) into `target` in `format`, display-encoded when
  // it is rgba8unorm. `owner` keeps these pipelines alive while the graph needs them.
  Result<TextureHandle> add_output(RenderGraph& graph, std::string name, TextureHandle history, TextureHandle target,
                                   gpu::Format format, std::shared_ptr<const void> owner) const;
};

// The history of a temporal pass (accumulate, taa): two textures kept between frames, last
// frame's result read from one while this frame's is written into the other, swapped every
// frame.
class HistoryTextures {
 public:
  // Makes the pair (sampled, colour attachments, `format`) at `size`, or again at a new size:
  // true when they are new, i.e. hold no history.
  Result<bool> ensure(gpu::Device& device, std::string_view label, gpu::Extent3D size, gpu::Format format);
  // This frame's pair in the graph: last frame's result as "<name>.history" (left sampled by
  // the frame before when `valid`; undefined otherwise) and the texture to write as
  // "<name>.history_next" (undefined: the draw covers every texel). Mark what is written into
  // it as an output in ShaderRead state (the next frame reads it from there). Swaps the pair.
  std::pair<TextureHandle, TextureHandle> import(RenderGraph& graph, std::string_view name, bool valid);

 private:
  std::array<std::optional<gpu::Texture>, 2> textures_;
  gpu::Extent3D size_{0, 0, 1};
  bool flip_ = false;
};

// Orthographic light matrix enclosing the box [lo, hi] seen along `towards_light` (the key
// light's shadow map; Vulkan depth 0..1).
mat4 fit_light_view_projection(vec3 towards_light, vec3 lo, vec3 hi);

// A camera for Vulkan's clip space (y down, depth 0..1, right-handed view).
mat4 perspective_vk(float vertical_fov_radians, float aspect, float near_plane, float far_plane);

}  // namespace weft::frame
