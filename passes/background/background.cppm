// weft.base_pass.background — draws the "environment" behind everything: a full-screen triangle
// at the far plane, depth-tested against "scene_depth" (read-only), into "scene_color".
module;
#include <expected>
#include <memory>
#include <string_view>
export module weft.base_pass.background;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;

export namespace weft::passes {

class BackgroundPass {
 public:
  static Result<BackgroundPass> create(gpu::Device& device);
  // Needs "frame_uniforms", "environment", "scene_color", "scene_depth"; updates "scene_color".
  Result<void> add(RenderGraph& graph, std::string_view name = "background") const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The pass type of the environment behind the scene (pass_type.cpp); weft::register_builtins() registers it.
const pipeline::PassTypeDescriptor& background_pass_type();

}  // namespace weft::passes
