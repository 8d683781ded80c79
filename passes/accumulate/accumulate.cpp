// The accumulate pass type: the running mean of a still view's jittered frames, in a history
// this pass keeps between frames (two textures, read one and write the other).
module;
#include <algorithm>
#include <array>
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <weft/try.h>
#include "weft_pass_accumulate_shaders.h"
module weft.base_pass.accumulate;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct Push {
  float weight;
  std::uint32_t display_encoded;
};
// The history is linear light in half floats whatever the input: 8 bits would round every
// step of the mean (1/255 is more than a 64th sample contributes to a dark pixel).
constexpr gpu::Format history_format = gpu::Format::RGBA16Float;

class AccumulateFramePass final : public pipeline::FramePass {
 public:
  explicit AccumulateFramePass(std::uint32_t frames) : frames_(frames) {}

  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    WEFT_TRY(gpu_, frame::TemporalPipelines::create(device, "accumulate", shaders::accumulate_frag(), 2, sizeof(Push)));
    device_ = &device;
    return {};
  }

  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    const std::string name(slots.pass_name());
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", name);
    const TextureHandle color = slots.input("color");
    const auto desc = graph.texture_desc(color);
    if (!desc || !gpu_->writes(desc->format))
      return fail(ErrorKind::Unsupported, "pass '{}': input 'color' must be rgba8unorm or rgba16float", name);
    const gpu::Extent3D size = desc->size.resolve({frame.width, frame.height, 1});

    // A new view (sample 0), a sample out of sequence (a frame was skipped or failed), or a
    // new size starts the mean afresh.
    const bool sequential = frame.sample_index > 0 && last_sample_ && frame.sample_index == *last_sample_ + 1;
    WEFT_TRY(const bool fresh, history_.ensure(*device_, name, size, history_format));
    count_ = fresh || !sequential ? 0 : count_ + 1;
    last_sample_ = frame.sample_index;

    const std::uint32_t n = std::min(count_ + 1, frames_);
    const Push push{.weight = 1.0f / float(n), .display_encoded = desc->format == gpu::Format::RGBA8Unorm ? 1u : 0u};
    const auto bytes = std::as_bytes(std::span(&push, 1));
    const std::vector<std::byte> push_bytes(bytes.begin(), bytes.end());

    const auto [history, next] = history_.import(graph, name, count_ > 0);
    WEFT_TRY(const TextureHandle blended,
             frame::add_fullscreen_pass(graph, {.name = name, .inputs = {color, history}, .target = next,
                                                .format = history_format, .push = push_bytes},
                                        gpu_->blend, gpu_->sampler, gpu_));
    graph.mark_output(blended, gpu::Access::ShaderRead);
    WEFT_TRY(const TextureHandle out, gpu_->add_output(graph, name + ".output", blended, slots.target("color"), desc->format, gpu_));
    slots.set_output("color", out);
    return {};
  }

 private:
  std::uint32_t frames_;
  std::shared_ptr<const frame::TemporalPipelines> gpu_;
  gpu::Device* device_ = nullptr;
  frame::HistoryTextures history_;
  std::uint32_t count_ = 0;  // samples in the history before this frame's
  std::optional<std::uint32_t> last_sample_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<AccumulateFramePass>(std::uint32_t(options.integer("frames")));
}

}  // namespace

const pipeline::PassTypeDescriptor& accumulate_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "accumulate",
      .summary = "Temporal accumulation of a still view: the mean of the frames the renderer jitters by Halton "
                 "sub-pixel offsets (RenderOptions::sample_index), kept between frames; converges towards "
                 "supersampling while the camera rests.",
      .doc = "docs/pipelines.md#accumulate",
      .inputs = {{.name = "color", .formats = {gpu::Format::RGBA8Unorm, frame::scene_color_format},
                  .meaning = "the colour to average (display-encoded colour is averaged as light)"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the mean of the samples so far"}},
      .options = {pipeline::integer_option("frames", 1, 4096, 64,
                                           "samples averaged with equal weight; later ones keep an exponential mean "
                                           "of about this many (1: no accumulation)",
                                           {1, 4, 16, 64})},
      .create = &create,
      .temporal = true,
  };
  return d;
}

}  // namespace weft::passes
