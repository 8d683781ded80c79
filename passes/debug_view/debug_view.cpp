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
    WEFT_TRY(const frame::SceneTargets shared,
             frame::scene_targets(graph.blackboard(),
                                  {.environment = false, .shadow_map = false, .color = false, .depth = false}));
    struct Data {
      BufferHandle uniforms;
      TextureHandle depth, target;
    };
    const TextureHandle depth = slots.input("depth");
    const TextureHandle target = slots.target("color");
    const std::string name(slots.pass_name());
    auto gpu = gpu_;
    const Push push = push_;
    auto& data = graph.add_pass<Data>(
        name,
        [&](PassBuilder& b, Data& d) {
          d.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
          d.depth = b.read(depth, TextureUse::Sampled);
          d.target = b.write(target ? target : b.create_texture(name + ".color", {.format = gpu::Format::RGBA8Unorm}),
                             TextureUse::ColorAttachment);
        },
        [gpu, push](const PassResources& res, const Data& d, PassContext& ctx) {
          const gpu::TextureView* in[] = {&res.view(d.depth)};
          frame::draw_fullscreen(ctx, gpu->pipeline, "debug_view", res.view(d.target), in, gpu->sampler,
                                 &res.buffer(d.uniforms), std::as_bytes(std::span(&push, 1)));
        });
    slots.set_output("color", data.target);
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
