// The fxaa pass type: FXAA over an 8-bit or HDR colour, its knobs in the options table.
module;
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <weft/try.h>
#include "weft_pass_fxaa_shaders.h"
module weft.base_pass.fxaa;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct Push {
  float threshold;
  float threshold_min;
  float subpixel;
  std::int32_t steps;
};
struct FxaaGpu {
  std::map<gpu::Format, frame::FullscreenPipeline> pipelines;  // by colour format
  gpu::Sampler sampler;  // bilinear, clamped: the blend across an edge is one filtered tap
};
constexpr gpu::Format color_formats[] = {gpu::Format::RGBA8Unorm, frame::scene_color_format};

class FxaaFramePass final : public pipeline::FramePass {
 public:
  explicit FxaaFramePass(Push push) : push_(push) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    std::map<gpu::Format, frame::FullscreenPipeline> pipelines;
    for (gpu::Format f : color_formats) {
      WEFT_TRY(auto p, frame::create_fullscreen_pipeline(device, "fxaa", shaders::fxaa_frag(), 1, false, sizeof(Push), f));
      pipelines.emplace(f, std::move(p));
    }
    WEFT_TRY(auto sampler, device.create_sampler({.label = "fxaa", .max_lod = 0}));
    gpu_ = std::make_shared<FxaaGpu>(FxaaGpu{std::move(pipelines), std::move(sampler)});
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    const TextureHandle color = slots.input("color");
    const auto desc = graph.texture_desc(color);
    if (!desc || !gpu_->pipelines.contains(desc->format))
      return fail(ErrorKind::Unsupported, "pass '{}': input 'color' must be rgba8unorm or rgba16float", slots.pass_name());
    const auto push = std::as_bytes(std::span(&push_, 1));
    WEFT_TRY(const TextureHandle out, frame::add_fullscreen_pass(graph,
                                                                 {.name = std::string(slots.pass_name()),
                                                                  .inputs = {color},
                                                                  .target = slots.target("color"),
                                                                  .format = desc->format,
                                                                  .push = {push.begin(), push.end()}},
                                                                 gpu_->pipelines.at(desc->format), gpu_->sampler, gpu_));
    slots.set_output("color", out);
    return {};
  }

 private:
  Push push_;
  std::shared_ptr<FxaaGpu> gpu_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<FxaaFramePass>(Push{float(options.number("threshold")), float(options.number("threshold_min")),
                                              float(options.number("subpixel")), std::int32_t(options.integer("steps"))});
}

}  // namespace

const pipeline::PassTypeDescriptor& fxaa_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "fxaa",
      .summary = "Fast approximate anti-aliasing (FXAA 3.11, quality) on the tone-mapped image: edges found by luma "
                 "contrast are blended across by their distance to the edge's end.",
      .doc = "docs/pipelines.md#fxaa",
      .inputs = {{.name = "color", .formats = {gpu::Format::RGBA8Unorm, frame::scene_color_format},
                  .meaning = "the display-encoded colour (after the tone map)"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the colour with its edges smoothed"}},
      .options = {pipeline::number_option("threshold", 0.0, 1.0, 0.125,
                                          "the contrast, relative to the brightest neighbour, below which a pixel is "
                                          "left alone (FXAA's 0.063 slow ... 0.333 fast)",
                                          {0.25, 0.166, 0.125, 0.063}),
                  pipeline::number_option("threshold_min", 0.0, 1.0, 0.0312,
                                          "the absolute contrast below which a pixel is left alone (dark areas)"),
                  pipeline::number_option("subpixel", 0.0, 1.0, 0.75,
                                          "how much a pixel unlike its 3x3 neighbourhood is blended (0 sharp, 1 soft)"),
                  pipeline::integer_option("steps", 1, 12, 12,
                                           "search steps along an edge for its ends (longer edges need more)",
                                           {2, 4, 8, 12})},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
