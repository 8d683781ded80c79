// weft.pass.forward — opaque standard (PBR) materials: creates the frame's HDR colour and
// depth ("scene_color", "scene_depth") and shades Lambert + GGX under the key light (with
// the "shadow_map") and the "environment". Feature passes then draw into the same targets.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <vector>
export module weft.pass.forward;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;

export namespace weft::passes {

inline constexpr gpu::Format scene_color_format = gpu::Format::RGBA16Float;
inline constexpr gpu::Format scene_depth_format = gpu::Format::Depth32Float;

class ForwardPass {
 public:
  static Result<ForwardPass> create(gpu::Device& device);
  // Needs "frame_uniforms", "shadow_map" and "environment" on the blackboard; puts
  // "scene_color" and "scene_depth". `items` must outlive the graph's execution.
  Result<void> add(RenderGraph& graph, std::span<const frame::DrawItem> items, vec4 clear_color = {0, 0, 0, 1}) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace weft::passes
