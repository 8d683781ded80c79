// weft.base_pass.background — draws the "environment" behind everything: a full-screen triangle
// at the far plane, depth-tested against "scene_depth" (read-only), into "scene_color".
module;
#include <expected>
#include <memory>
export module weft.base_pass.background;
import weft.core;
import weft.gpu;
import weft.graph;

export namespace weft::passes {

class BackgroundPass {
 public:
  static Result<BackgroundPass> create(gpu::Device& device);
  // Needs "frame_uniforms", "environment", "scene_color", "scene_depth"; updates "scene_color".
  Result<void> add(RenderGraph& graph) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace weft::passes
