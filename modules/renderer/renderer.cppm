// weft.renderer — turns a scene and a pipeline into a frame: instantiates the pipeline's
// passes from the pass-type registry (weft.pipeline; the scene's "pipeline" file, or the
// default one), lets the scene-colour stage add the features the scene's materials use, builds
// and compiles the graph, executes it and reads the image (and any resource asked for) back.
// A material that is not "standard" is drawn by the registered feature of its type
// (weft::feature_registry()); the renderer names no pass and no feature. GPU meshes,
// environment maps and pass instances are cached across frames.
module;
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>
export module weft.renderer;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.frame;
export import weft.feature;
export import weft.pipeline;

export namespace weft::renderer {

using weft::Quality;
using weft::quality_from_string;

struct RenderOptions {
  std::uint32_t width = 0, height = 0;  // 0: the scene's output size
  Quality quality = Quality::Medium;
  float exposure = 1.0f;
  bool aces = true;          // ACES tone curve; false: plain clamp (for analytic checks)
  bool timestamps = true;
  // Submit and wait after every pass and time each alone (ExecuteOptions::serial_passes): the
  // honest per-pass cost on CPU adapters, whose timestamps leave out vertex work.
  bool serial_passes = false;
  // Also read back the scene colour before tone mapping into Frame::hdr (linear RGBA float):
  // what stability tests inspect, since NaN and infinity do not survive the 8-bit output.
  bool read_hdr = false;
  // Temporal accumulation of a still view (docs/anti-aliasing.md): sample k > 0 moves the
  // projection by the k-th point of the Halton (2, 3) sequence, within one pixel, and tells
  // the passes (PassFrame::sample_index) so an `accumulate` pass averages it into its history;
  // 0 is the unjittered frame and starts the history afresh. The caller counts: the viewer
  // counts frames while the camera rests, `weft render --accumulate N` renders 0 .. N-1.
  std::uint32_t sample_index = 0;
  // The frame to render; null: the scene's "pipeline" file, or the default pipeline. Must
  // outlive the call.
  const pipeline::Pipeline* pipeline = nullptr;
  // Or a pipeline file, read again whenever it changes on disk (the viewer's hot reload);
  // it takes precedence over the scene's "pipeline". Ignored when `pipeline` is set.
  std::filesystem::path pipeline_file;
  // Render the frame's image into this texture of the caller's (same device; the frame's size,
  // rgba8unorm, color-attachment usage) and read nothing back: Frame::image stays empty. It is
  // left in `target_final_state` for what the caller does next (sampling it, a blit, a copy).
  const gpu::Texture* target = nullptr;
  gpu::Access target_final_state = gpu::Access::ShaderRead;
  // Resources to read back into Frame::outputs: a pass's output slot ("background.color",
  // "scene.depth") or the name of any texture of the compiled frame ("ssdf_visibility").
  std::vector<std::string> outputs;
};

// A resource read back for RenderOptions::outputs, as linear RGBA floats (8-bit formats
// scaled to 0..1, sRGB decoded; one-channel colour as grey; depth in red, green and blue 0).
struct Readback {
  std::string name;
  gpu::Format format = gpu::Format::Undefined;  // the resource's own format
  image::Image pixels;
};

struct Frame {
  image::Image8 image;        // RGBA, sRGB-encoded (empty when RenderOptions::target took it)
  image::Image hdr;           // RGBA linear scene colour before the tone curve (RenderOptions::read_hdr)
  FrameStats stats;           // per-pass GPU and CPU times, transient memory
  std::vector<std::string> passes;  // the passes that ran, in order
  std::vector<std::string> warnings;
  std::vector<Readback> outputs;  // RenderOptions::outputs, in that order
};

// A picture of a read-back resource for a PNG or the viewer (docs/pipelines.md#any-resource-in-a-file):
// 8-bit formats keep their bytes; float colour is clamped to [0, 1] and sRGB-encoded; depth
// is grey from white (the nearest texel drawn) to dark grey (the farthest drawn), black where
// nothing was drawn (depth 1). RGBA, sRGB-encoded.
image::Image8 picture(const Readback& resource);

// The compiled graph of a scene without executing it: for `weft graph` and tests.
struct GraphReport {
  std::string dot;
  std::string dump;
  std::vector<std::string> passes;         // executed passes, in order
  std::vector<std::string> culled_passes;
  std::vector<std::string> resources;      // every resource of the frame, by declaration
  std::vector<std::string> slots;          // every pass output of the pipeline, "pass.slot"
  std::string pipeline;                    // the pipeline as a file (pipeline::to_json)
  std::vector<std::string> warnings;       // the pipeline's (passes reaching no output)
};

class Renderer {
 public:
  // On a gpu::Device::create_declaring() device a renderer declares and compiles frames
  // (describe) and renders none: features skip their bakes, nothing is uploaded.
  static Result<Renderer> create(gpu::Device& device);
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;
  ~Renderer();

  Result<Frame> render(const scene::Scene& scene, const RenderOptions& options = {});
  // The frame compiled, not executed. `inspect`, when given, sees the compiled graph (the
  // test kit's expectations on order, barriers and memory) before the report is made.
  Result<GraphReport> describe(const scene::Scene& scene, const RenderOptions& options = {},
                               const std::function<void(const CompiledGraph&)>& inspect = {});
  // The pipeline render() uses for `scene` with `options`: options.pipeline, else the options'
  // or the scene's pipeline file (read again only when its modification time changed), else
  // the default pipeline. Valid until the next call that re-reads the same file.
  Result<const pipeline::Pipeline*> pipeline_for(const scene::Scene& scene, const RenderOptions& options = {});

  // How many times each cache did real work (tests assert the second frame does none).
  struct CacheStats {
    std::uint32_t mesh_uploads = 0, environment_uploads = 0, texture_uploads = 0, pass_creations = 0;
    // Frames whose graph was planned afresh, and frames that reused the last frame's plan
    // (and its transient textures: RenderGraph::reset()).
    std::uint32_t graph_plans = 0, graph_plans_reused = 0;
  };
  [[nodiscard]] CacheStats cache_stats() const;

 private:
  Renderer() = default;
  struct State;
  std::unique_ptr<State> state_;
};

// A scene's frame declared and compiled with no adapter and no Vulkan driver: a renderer on
// gpu::Device::create_declaring(). Passes, culling, order, barriers and transient memory
// (estimated, as for any compile without a device) are those a device would get; bakes do
// not run, so the sizes of assets only a bake knows (an SSDF's cluster data) are
// placeholders. `weft graph` and `weft graph check` use it.
Result<GraphReport> describe(const scene::Scene& scene, const RenderOptions& options = {},
                             const std::function<void(const CompiledGraph&)>& inspect = {});

// True when scene object `index` is flat (every vertex on one plane) and nothing the camera
// can see lies behind it as seen from the light (`towards_light`): the other objects' boxes
// are on its lit side (seen from that side, dipping into it by up to 0.1 % of the scene's
// size counts as resting on it), or, for an opaque (standard) object seen from its lit side,
// their parts behind it are hidden by it (it must then be a filled rectangle). Such an object
// shadows nothing visible, so the key light's shadow map leaves it out: a floor under the
// scene covered most of the map.
// Asked for one object it compares that object with every other: the reference for
// select_shadow_casters, which the renderer uses.
[[nodiscard]] bool shadows_nothing_visible(const scene::Scene& scene, std::uint32_t index, vec3 towards_light);

// The same rule for every object at once, in O(n log n) for n objects (the boxes in a
// bounding-volume hierarchy) instead of n - 1 box tests per flat object: element i is false
// exactly when shadows_nothing_visible(scene, i, towards_light) is true, i.e. the shadow map
// draws the objects whose element is true. `stats`, when given, says how much work it did.
struct ShadowCasterStats {
  std::uint64_t flat_objects = 0;  // objects that needed the other objects' boxes
  std::uint64_t boxes_tested = 0;  // boxes given the exact test (the reference: n - 1 per flat object)
};
[[nodiscard]] std::vector<bool> select_shadow_casters(const scene::Scene& scene, vec3 towards_light,
                                                      ShadowCasterStats* stats = nullptr);

}  // namespace weft::renderer

// Shared by the implementation units (not exported).
namespace weft::renderer::detail {
std::uint64_t content_hash(const scene::Environment& env);
struct EnvironmentTexels {
  std::uint32_t width = 4, height = 2;
  std::vector<vec4> rgba;
  std::vector<float> rgb;
};
EnvironmentTexels environment_texels(const scene::Environment& env);
}  // namespace weft::renderer::detail
