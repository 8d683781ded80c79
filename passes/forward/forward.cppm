// weft.base_pass.forward — opaque standard (PBR) materials: creates the frame's HDR colour and
// depth (frame::SceneTargets) and shades Lambert + GGX under the key light (with the shadow
// map) and the environment. Feature passes then draw into the same targets.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <vector>
export module weft.base_pass.forward;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;
import weft.frame;

export namespace weft::passes {

using frame::scene_color_format;
using frame::scene_depth_format;

class ForwardPass {
 public:
  static Result<ForwardPass> create(gpu::Device& device);
  // The frame's first lit pass (frame::add_scene_color_pass with a clear colour): needs the
  // uniforms, shadow map and environment of frame::SceneTargets on the blackboard, creates
  // and puts the scene colour and depth, of `samples` samples (MSAA). `items` must outlive the
  // graph's execution.
  Result<void> add(RenderGraph& graph, std::span<const frame::DrawItem> items, vec4 clear_color = {0, 0, 0, 1},
                   std::uint32_t samples = 1) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The pass type of the scene colour stage (pass_type.cpp); weft::register_builtins() registers it.
const pipeline::PassTypeDescriptor& scene_color_pass_type();

}  // namespace weft::passes
