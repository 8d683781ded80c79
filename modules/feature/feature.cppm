// weft.feature — the contract between the renderer and a feature (fur, skin, SSDF, neural
// BTF): a FeaturePass is created only when a scene uses its material type, prepares its
// assets (bakes cached by content hash), and adds its passes to the frame's graph.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.feature;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;

export namespace weft {

// Quality presets; each feature maps them to its own knobs (documented in docs/tradeoffs.md).
enum class Quality : std::uint8_t { Low, Medium, High, Reference };
std::string_view to_string(Quality quality);
Result<Quality> quality_from_string(std::string_view name);

// What a feature sees of the frame being built.
struct FeatureFrame {
  gpu::Device& device;
  const scene::Scene& scene;
  std::span<const std::uint32_t> objects;            // scene.objects using this feature's materials
  std::span<const frame::GpuMesh* const> meshes;     // the GPU mesh of each scene mesh, by index
  const frame::FrameUniforms& uniforms;
  Quality quality = Quality::Medium;
  std::uint32_t width = 0, height = 0;
};

// A feature's hook into the frame. add_passes() finds "frame_uniforms", "environment",
// "shadow_map", "scene_color" and "scene_depth" on the blackboard and puts back the new
// versions of "scene_color" (and "scene_depth" when it draws opaque geometry). Anything
// its execute callbacks use (draw lists, matrices) must live in the FeaturePass object.
class FeaturePass {
 public:
  virtual ~FeaturePass() = default;
  [[nodiscard]] virtual std::string_view name() const = 0;
  // Parses the materials' parameters (errors name their JSON path) and prepares assets.
  virtual Result<void> prepare(const FeatureFrame& frame) = 0;
  virtual Result<void> add_passes(RenderGraph& graph, const FeatureFrame& frame) = 0;
  // Messages for the user (clamped knobs, weak inputs), gathered after prepare().
  [[nodiscard]] virtual std::vector<std::string> warnings() const { return {}; }
};

using FeatureFactory = Result<std::unique_ptr<FeaturePass>> (*)(gpu::Device& device);

// Scene meshes in weft's vertex layout, and a key of their content for caches (the
// renderer's and the features' GPU copies of the same mesh agree on it).
std::uint64_t mesh_content_hash(const scene::Mesh& mesh);
frame::MeshData to_mesh_data(const scene::Mesh& mesh);

}  // namespace weft
