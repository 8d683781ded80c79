// The shadow_map pass type: ShadowPass in a pipeline. Without a key light it adds nothing and
// its output is empty this frame (the scene colour then reads a far-plane placeholder).
module;
#include <algorithm>
#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <weft/try.h>
module weft.base_pass.shadow;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;

namespace weft::passes {
namespace {

std::uint32_t resolution_for(Quality q) {
  switch (q) {
    case Quality::Low: return 1024;
    case Quality::Medium: return 2048;
    case Quality::High: return 4096;
    case Quality::Reference: return 8192;
  }
  return 2048;
}

class ShadowMapFramePass final : public pipeline::FramePass {
 public:
  explicit ShadowMapFramePass(std::uint32_t resolution) : resolution_(resolution) {}

  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame& frame) override {
    if (!frame.key_light) return {};
    const std::uint32_t wanted = std::min(resolution_ ? resolution_ : resolution_for(frame.quality),
                                          device.adapter_info().limits.max_texture_dimension_2d);
    if (shadow_ && shadow_->settings().resolution == wanted) return {};
    shadow_.reset();
    WEFT_TRY(auto pass, ShadowPass::create(device, {.resolution = wanted}));
    shadow_.emplace(std::move(pass));
    return {};
  }

  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    if (!frame.key_light) return {};
    if (!shadow_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    slots.set_output("depth", shadow_->add(graph, frame.shadow_casters, frame.uniforms.light_view_projection, slots.pass_name()));
    return {};
  }

 private:
  std::uint32_t resolution_;
  std::optional<ShadowPass> shadow_;  // execute callbacks point at it: never moved once made
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<ShadowMapFramePass>(std::uint32_t(options.integer("resolution")));
}

}  // namespace

const pipeline::PassTypeDescriptor& shadow_map_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "shadow_map",
      .summary = "Depth of every shadow caster seen from the key light (the scene's first directional light); "
                 "nothing when the scene has none.",
      .doc = "docs/pipelines.md#shadow_map",
      .inputs = {},
      .outputs = {{.name = "depth", .formats = {gpu::Format::Depth32Float}, .size = pipeline::SlotSize::Any,
                   .meaning = "the key light's depth, resolution x resolution"}},
      // The stability sweep stops at 8192 (256 MiB): 16384 texels per side are 1 GiB of depth.
      .options = {pipeline::with_extremes(
          pipeline::integer_option("resolution", 0, 16384, 0,
                                   "texels per side; 0: by quality (1024 low, 2048 medium, 4096 high, 8192 "
                                   "reference), at most the adapter's limit",
                                   {256, 512, 1024, 2048, 4096}),
          std::nullopt, 8192)},
      .create = &create,
      // Shadow edges converge as texels shrink below a pixel's footprint; 8192 is the
      // reference preset's size (and within every desktop adapter's limit).
      .reference = {{"resolution", 8192}},
      .reference_why = "8192 texels per side: the reference preset's shadow map",
  };
  return d;
}

}  // namespace weft::passes
