// The fxaa pass type: FXAA over an 8-bit or HDR colour, its knobs in the options table.
module;
#include <cstdint>
#include <expected>
#include <optional>
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
class FxaaFramePass final : public pipeline::FramePass {
 public:
  explicit FxaaFramePass(Push push) : push_(push) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (effect_) return {};
    // Bilinear, clamped: the blend across an edge is one filtered tap.
    WEFT_TRY(auto effect, frame::ColorEffect::create(device, "fxaa", shaders::fxaa_frag(), 1, false, sizeof(Push),
                                                     {.max_lod = 0}));
    effect_.emplace(std::move(effect));
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!effect_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    WEFT_TRY(const TextureHandle out, effect_->add(graph, slots.pass_name(), {slots.input("color")}, slots.target("color"),
                                                   std::as_bytes(std::span(&push_, 1))));
    slots.set_output("color", out);
    return {};
  }

 private:
  Push push_;
  std::optional<frame::ColorEffect> effect_;
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
                  .intended_formats = {gpu::Format::RGBA8Unorm},
                  .intended_why = "FXAA's contrast thresholds are for display-encoded luma: on linear HDR colour it "
                                  "misses edges in the dark and smooths bright ones too much; put it after the tonemap",
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
