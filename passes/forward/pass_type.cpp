// The scene_color pass type: the scene-colour stage. The forward pass draws the standard
// materials into new colour and depth targets, then every feature the scene's materials use
// draws into them (PassFrame::add_feature_passes), so features stay material-driven whatever
// the pipeline around them.
module;
#include <bit>
#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <span>
#include <weft/try.h>
module weft.base_pass.forward;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

class SceneColorFramePass final : public pipeline::FramePass {
 public:
  SceneColorFramePass(vec4 clear, std::uint32_t samples) : clear_(clear), samples_(samples) {}

  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    // Asked here, by the option's name, rather than when the graph creates the targets.
    const gpu::Limits& limits = device.adapter_info().limits;
    if (const std::uint32_t counts = limits.color_sample_counts & limits.depth_sample_counts; !(counts & samples_))
      return fail(ErrorKind::Unsupported, "option 'msaa' is {}: adapter '{}' renders colour and depth with {} samples",
                  samples_, device.adapter_info().name, gpu::sample_counts_text(counts));
    if (!forward_) {
      WEFT_TRY(auto pass, ForwardPass::create(device));
      forward_.emplace(std::move(pass));
    }
    if (!no_shadow_) {
      // 1x1 at the far plane: what the lit passes sample when the frame has no shadow map.
      WEFT_TRY(auto t, device.create_texture({.label = "no_shadow", .size = {1, 1, 1}, .format = gpu::Format::Depth32Float,
                                              .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst}));
      const float far_depth = 1.0f;
      WEFT_TRY_VOID(device.queue().write_texture(t, std::as_bytes(std::span(&far_depth, 1))));
      no_shadow_.emplace(std::move(t));
    }
    return {};
  }

  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    if (!forward_ || !no_shadow_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    auto& board = graph.blackboard();
    TextureHandle shadow = slots.input("shadow_map");
    if (!shadow) shadow = graph.import_texture("no_shadow", &*no_shadow_, gpu::Access::ShaderRead);
    frame::put_scene_targets(board, {.shadow_map = shadow});
    WEFT_TRY_VOID(forward_->add(graph, frame.items, clear_, samples_));
    if (frame.add_feature_passes) WEFT_TRY_VOID(frame.add_feature_passes(graph));
    WEFT_TRY(const frame::SceneTargets targets, frame::scene_targets(board, {.environment = false}));
    slots.set_output("color", targets.color);
    slots.set_output("depth", targets.depth);
    return {};
  }

 private:
  vec4 clear_;
  std::uint32_t samples_ = 1;
  std::optional<ForwardPass> forward_;
  std::optional<gpu::Texture> no_shadow_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  const float v = float(options.number("clear"));
  const auto samples = std::uint32_t(options.integer("msaa"));
  if (std::popcount(samples) != 1)
    return fail(ErrorKind::InvalidArgument, "option 'msaa' is {}: a sample count is 1, 2, 4, 8, 16, 32 or 64", samples);
  return std::make_unique<SceneColorFramePass>(vec4(v, v, v, 1.0f), samples);
}

}  // namespace

const pipeline::PassTypeDescriptor& scene_color_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "scene_color",
      .summary = "The scene-colour stage: standard (PBR) materials drawn forward, then every feature the scene's "
                 "materials use (fur, skin, SSDF, neural BTF, a plugin's), into one HDR colour and depth.",
      .doc = "docs/pipelines.md#scene_color",
      .inputs = {{.name = "shadow_map", .formats = {gpu::Format::Depth32Float}, .size = pipeline::SlotSize::Any,
                  .optional = true, .meaning = "the key light's depth; unconnected: unshadowed"}},
      .outputs = {{.name = "color", .formats = {frame::scene_color_format},
                   .meaning = "linear HDR radiance (multisampled with msaa > 1: resolved for passes that read texels)"},
                  {.name = "depth", .formats = {frame::scene_depth_format}, .meaning = "the camera's depth (0 near, 1 far)"}},
      .options = {pipeline::number_option("clear", 0.0, 1e6, 0.0,
                                          "grey level the colour is cleared to before drawing (the background "
                                          "pass covers it where the environment shows)"),
                  // 4 is the largest count Vulkan guarantees (lavapipe has 1 and 4): the stability
                  // sweep's maximum; 2 and 8 where the adapter has them.
                  pipeline::with_extremes(
                      pipeline::integer_option("msaa", 1, 64, 1,
                                               "samples per pixel of the colour and depth (MSAA; 1 is off): edges "
                                               "are covered per sample and shaded once per pixel; fur by coverage "
                                               "or per sample (its msaa_hair knob)",
                                               {1, 4}),
                      std::nullopt, 4.0)},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
