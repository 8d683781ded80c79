// The background pass type: the environment drawn where the depth is at the far plane.
module;
#include <expected>
#include <memory>
#include <optional>
#include <weft/try.h>
module weft.base_pass.background;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

class BackgroundFramePass final : public pipeline::FramePass {
 public:
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (pass_) return {};
    WEFT_TRY(auto pass, BackgroundPass::create(device));
    pass_.emplace(std::move(pass));
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!pass_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    auto& board = graph.blackboard();
    frame::put_scene_targets(board, {.color = slots.input("color"), .depth = slots.input("depth")});
    WEFT_TRY_VOID(pass_->add(graph, slots.pass_name()));
    WEFT_TRY(const frame::SceneTargets targets,
             frame::scene_targets(board, {.uniforms = false, .environment = false, .shadow_map = false, .depth = false}));
    slots.set_output("color", targets.color);
    return {};
  }

 private:
  std::optional<BackgroundPass> pass_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions&) {
  return std::make_unique<BackgroundFramePass>();
}

}  // namespace

const pipeline::PassTypeDescriptor& background_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "background",
      .summary = "The scene's environment (its HDR map or constant colour) drawn behind everything: where the depth "
                 "is at the far plane.",
      .doc = "docs/pipelines.md#background",
      .inputs = {{.name = "color", .formats = {frame::scene_color_format}, .multisampled = true,
                  .meaning = "the scene colour to draw into (multisampled or not)"},
                 {.name = "depth", .formats = {frame::scene_depth_format}, .multisampled = true,
                  .meaning = "the scene's depth (read only), of the colour's sample count"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the colour with the environment behind"}},
      .options = {},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
