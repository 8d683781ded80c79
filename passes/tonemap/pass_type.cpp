// The tonemap pass type: linear HDR to the 8-bit sRGB image. Written into the frame's output
// target when it is the frame's image, into a transient otherwise (a pass after it may read it).
module;
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <weft/try.h>
module weft.base_pass.tonemap;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;

namespace weft::passes {
namespace {

class TonemapFramePass final : public pipeline::FramePass {
 public:
  TonemapFramePass(float exposure, ToneOperator op) : exposure_(exposure), operator_(op) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (pass_) return {};
    WEFT_TRY(auto pass, TonemapPass::create(device));
    pass_.emplace(std::move(pass));
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    if (!pass_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    const TextureHandle color = slots.input("color");
    if (!color) return fail(ErrorKind::Graph, "pass '{}': its input 'color' is empty this frame", slots.pass_name());
    const TonemapSettings settings{.exposure = exposure_ * frame.exposure,
                                   .tone_operator = frame.aces ? operator_ : ToneOperator::Clamp};
    WEFT_TRY(auto out, pass_->add(graph, color, slots.target("color"), settings, slots.pass_name()));
    slots.set_output("color", out);
    return {};
  }

 private:
  float exposure_;
  ToneOperator operator_;
  std::optional<TonemapPass> pass_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<TonemapFramePass>(float(options.number("exposure")),
                                            options.choice("operator") == "clamp" ? ToneOperator::Clamp : ToneOperator::Aces);
}

}  // namespace

const pipeline::PassTypeDescriptor& tonemap_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "tonemap",
      .summary = "Linear HDR colour to the 8-bit sRGB image: exposure, then the ACES filmic curve or a plain clamp.",
      .doc = "docs/pipelines.md#tonemap",
      .inputs = {{.name = "color", .formats = {gpu::Format::RGBA16Float, gpu::Format::RGBA32Float},
                  .linear_source = true, .meaning = "linear HDR radiance"}},
      .outputs = {{.name = "color", .formats = {output_format}, .meaning = "sRGB-encoded colour"}},
      .options = {pipeline::number_option("exposure", 1e-6, 1e6, 1.0,
                                          "multiplies the radiance before the curve (times `weft render --exposure`)"),
                  pipeline::choice_option("operator", {"aces", "clamp"}, "aces",
                                          "aces: the ACES filmic fit; clamp: min(x, 1), for analytic checks")},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
