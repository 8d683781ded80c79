module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <string>
#include <weft/try.h>
#include "weft_pass_debug_view_shaders.h"
module weft.base_pass.debug_view;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct Push {
  std::uint32_t view;
  float near_distance, far_distance;
};
struct DebugGpu {
  frame::FullscreenPipeline pipeline;
  gpu::Sampler sampler;
};

class DebugViewFramePass final : public pipeline::FramePass {
 public:
  explicit DebugViewFramePass(Push push) : push_(push) {}
  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    WEFT_TRY(auto p, frame::create_fullscreen_pipeline(device, "debug_view", shaders::debug_view_frag(), 1, true,
                                                      sizeof(Push), gpu::Format::RGBA8Unorm));
    WEFT_TRY(auto sampler, device.create_sampler({.label = "debug_view", .mag_filter = gpu::FilterMode::Nearest,
                                                  .min_filter = gpu::FilterMode::Nearest, .max_lod = 0}));
    gpu_ = std::make_shared<DebugGpu>(DebugGpu{std::move(p), std::move(sampler)});
    return {};
  }
  Result<void> add(RenderGraph& graph, const pipeline::PassFrame&, pipeline::PassSlots& slots) override {
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    const auto push = std::as_bytes(std::span(&push_, 1));
    WEFT_TRY(const TextureHandle out,
             frame::add_fullscreen_pass(graph,
                                        {.name = std::string(slots.pass_name()),
                                         .inputs = {slots.input("depth")},
                                         .target = slots.target("color"),
                                         .format = gpu::Format::RGBA8Unorm,
                                         .push = {push.begin(), push.end()}},
                                        gpu_->pipeline, gpu_->sampler, gpu_));
    slots.set_output("color", out);
    return {};
  }

 private:
  Push push_;
  std::shared_ptr<DebugGpu> gpu_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  const double near_distance = options.number("near"), far_distance = options.number("far");
  if (!(far_distance > near_distance))
    return fail(ErrorKind::InvalidArgument, "debug_view: option 'far' ({}) must be larger than 'near' ({})", far_distance,
                near_distance);
  return std::make_unique<DebugViewFramePass>(
      Push{options.choice("view") == "normals" ? 1u : 0u, float(near_distance), float(far_distance)});
}

}  // namespace

const pipeline::PassTypeDescriptor& debug_view_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "debug_view",
      .summary = "A picture of the camera's depth: distance as grey (white at `near`, black at `far`), or world "
                 "normals reconstructed from it (n * 0.5 + 0.5); black where nothing was drawn.",
      .doc = "docs/pipelines.md#debug_view",
      .inputs = {{.name = "depth", .formats = {frame::scene_depth_format}, .meaning = "the camera's depth"}},
      .outputs = {{.name = "color", .formats = {gpu::Format::RGBA8Unorm}, .meaning = "the picture"}},
      .options = {pipeline::choice_option("view", {"depth", "normals"}, "depth",
                                          "depth: distance to the camera; normals: geometric world normals"),
                  pipeline::number_option("near", 0.0, 1e6, 0.0, "distance shown white (scene units)"),
                  pipeline::number_option("far", 1e-6, 1e6, 20.0, "distance shown black (scene units)")},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
