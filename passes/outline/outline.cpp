module;
#include <cstdint>
#include <expected>
#include <optional>
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
class OutlineFramePass final : public pipeline::FramePass {
 public:
  explicit OutlineFramePass(Push push) : push_(push) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (effect_) return {};
    WEFT_TRY(auto effect, frame::ColorEffect::create(device, "outline", shaders::outline_frag(), 2, true, sizeof(Push),
                                                     {.mag_filter = gpu::FilterMode::Nearest,
                                                      .min_filter = gpu::FilterMode::Nearest, .max_lod = 0}));
    effect_.emplace(std::move(effect));
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!effect_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    WEFT_TRY(const TextureHandle out,
             effect_->add(graph, slots.pass_name(), {slots.input("color"), slots.input("depth")}, slots.target("color"),
                          std::as_bytes(std::span(&push_, 1))));
    slots.set_output("color", out);
    return {};
  }

 private:
  Push push_;
  std::optional<frame::ColorEffect> effect_;
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
