module;
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <weft/try.h>
#include "weft_pass_outline_shaders.h"
module weft.base_pass.outline;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct Push {
  float threshold;
  std::int32_t thickness;
  float brightness;
};
struct OutlineGpu {
  std::map<gpu::Format, frame::FullscreenPipeline> pipelines;  // by colour format
  gpu::Sampler sampler;
};
constexpr gpu::Format color_formats[] = {gpu::Format::RGBA8Unorm, frame::scene_color_format};

class OutlineFramePass final : public pipeline::FramePass {
 public:
  explicit OutlineFramePass(Push push) : push_(push) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    std::map<gpu::Format, frame::FullscreenPipeline> pipelines;
    for (gpu::Format f : color_formats) {
      WEFT_TRY(auto p, frame::create_fullscreen_pipeline(device, "outline", shaders::outline_frag(), 2, true, sizeof(Push), f));
      pipelines.emplace(f, std::move(p));
    }
    WEFT_TRY(auto sampler, device.create_sampler({.label = "outline", .mag_filter = gpu::FilterMode::Nearest,
                                                  .min_filter = gpu::FilterMode::Nearest, .max_lod = 0}));
    gpu_ = std::make_shared<OutlineGpu>(OutlineGpu{std::move(pipelines), std::move(sampler)});
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    const TextureHandle color = slots.input("color"), depth = slots.input("depth");
    const auto desc = graph.texture_desc(color);
    if (!desc || !gpu_->pipelines.contains(desc->format))
      return fail(ErrorKind::Unsupported, "pass '{}': input 'color' must be rgba8unorm or rgba16float", slots.pass_name());
    const auto push = std::as_bytes(std::span(&push_, 1));
    WEFT_TRY(const TextureHandle out, frame::add_fullscreen_pass(graph,
                                                                 {.name = std::string(slots.pass_name()),
                                                                  .inputs = {color, depth},
                                                                  .target = slots.target("color"),
                                                                  .format = desc->format,
                                                                  .push = {push.begin(), push.end()}},
                                                                 gpu_->pipelines.at(desc->format), gpu_->sampler, gpu_));
    slots.set_output("color", out);
    return {};
  }

 private:
  Push push_;
  std::shared_ptr<OutlineGpu> gpu_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<OutlineFramePass>(Push{float(options.number("threshold")),
                                                 std::int32_t(options.integer("thickness")),
                                                 float(options.number("brightness"))});
}

}  // namespace

const pipeline::PassTypeDescriptor& outline_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "outline",
      .summary = "Lines where the distance to the camera jumps by more than `threshold` of the nearer distance "
                 "(silhouettes, and objects in front of others), over the tone-mapped image or the HDR colour.",
      .doc = "docs/pipelines.md#outline",
      .inputs = {{.name = "color", .formats = {gpu::Format::RGBA8Unorm, frame::scene_color_format},
                  .meaning = "the colour to draw over"},
                 {.name = "depth", .formats = {frame::scene_depth_format}, .meaning = "the camera's depth"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the colour with outlines"}},
      .options = {pipeline::number_option("threshold", 1e-4, 100.0, 0.05,
                                          "relative jump in distance that makes an edge (0.05: 5 %)"),
                  pipeline::integer_option("thickness", 1, 8, 1, "how far apart (texels) the compared depths are"),
                  pipeline::number_option("brightness", 0.0, 1.0, 0.0, "the lines' grey level (0 black, 1 white)")},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
