module;
#include <algorithm>
#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <weft/try.h>
#include "weft_pass_bloom_shaders.h"
module weft.base_pass.bloom;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct DownPush {
  vec2 source_texel;
};
struct UpPush {
  vec2 coarser_texel;
  float radius;
};
struct CombinePush {
  vec2 chain_texel;
  float radius, intensity, inverse_levels;
};

struct BloomGpu {
  frame::FullscreenPipeline down, up, combine;
  gpu::Sampler sampler;  // linear, mirrored at the edges (see prepare)
};

class BloomFramePass final : public pipeline::FramePass {
 public:
  BloomFramePass(float intensity, std::uint32_t levels, float radius)
      : intensity_(intensity), levels_(levels), radius_(radius) {}

  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    const auto format = frame::scene_color_format;
    WEFT_TRY(auto down, frame::create_fullscreen_pipeline(device, "bloom_down", shaders::bloom_down_frag(), 1, false,
                                                         sizeof(DownPush), format));
    WEFT_TRY(auto up, frame::create_fullscreen_pipeline(device, "bloom_up", shaders::bloom_up_frag(), 2, false,
                                                       sizeof(UpPush), format));
    WEFT_TRY(auto combine, frame::create_fullscreen_pipeline(device, "bloom_combine", shaders::bloom_combine_frag(), 2,
                                                            false, sizeof(CombinePush), format));
    // Mirrored at the edges: a tap past the border reads the texel it mirrors, so the chain
    // loses less of the frame's energy at the borders than clamping, which counts the edge
    // texels twice (tests/renderer/test_pipeline_render.cpp measures what is left).
    WEFT_TRY(auto sampler, device.create_sampler({.label = "bloom", .address_mode = gpu::AddressMode::MirrorRepeat, .max_lod = 0}));
    gpu_ = std::make_shared<BloomGpu>(BloomGpu{std::move(down), std::move(up), std::move(combine), std::move(sampler)});
    return {};
  }

  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", slots.pass_name());
    const TextureHandle color = slots.input("color");
    if (!color) return fail(ErrorKind::Graph, "pass '{}': its input 'color' is empty this frame", slots.pass_name());
    // As many halvings as asked for, while the smaller side keeps at least 2 texels.
    std::uint32_t levels = 0;
    for (std::uint32_t side = std::min(frame.width, frame.height); levels < levels_ && side >= 4; side /= 2) ++levels;
    levels = std::max(levels, 1u);
    const std::string name(slots.pass_name());
    // One texel of level k (level 0: the frame), in uv units.
    const auto texel_of = [&](std::uint32_t level) {
      return vec2(1.0f / float(std::max(1u, frame.width >> level)), 1.0f / float(std::max(1u, frame.height >> level)));
    };
    auto gpu = gpu_;
    struct Step {
      TextureHandle source, coarser, target;
    };
    // Down: d[k] = filter(d[k-1]), d[0] = the colour.
    std::vector<TextureHandle> down{color};
    for (std::uint32_t k = 1; k <= levels; ++k) {
      const DownPush push{texel_of(k - 1)};
      auto& step = graph.add_pass<Step>(
          weft::format("{}.down{}", name, k),
          [&](PassBuilder& b, Step& d) {
            d.source = b.read(down.back(), TextureUse::Sampled);
            d.target = b.write(b.create_texture(weft::format("{}.level{}", name, k),
                                                {.size = RelativeSize(1.0f / float(1u << k)), .format = frame::scene_color_format}),
                               TextureUse::ColorAttachment);
          },
          [gpu, push](const PassResources& res, const Step& d, PassContext& ctx) {
            const gpu::TextureView* in[] = {&res.view(d.source)};
            frame::draw_fullscreen(ctx, gpu->down, "bloom_down", res.view(d.target), in, gpu->sampler, nullptr,
                                   std::as_bytes(std::span(&push, 1)));
          });
      down.push_back(step.target);
    }
    // Up: u[levels] = d[levels], u[k] = d[k] + tent(u[k+1]).
    TextureHandle up = down[levels];
    for (std::uint32_t k = levels - 1; k >= 1; --k) {
      const UpPush push{texel_of(k + 1), radius_};
      auto& step = graph.add_pass<Step>(
          weft::format("{}.up{}", name, k),
          [&](PassBuilder& b, Step& d) {
            d.source = b.read(down[k], TextureUse::Sampled);
            d.coarser = b.read(up, TextureUse::Sampled);
            d.target = b.write(b.create_texture(weft::format("{}.sum{}", name, k),
                                                {.size = RelativeSize(1.0f / float(1u << k)), .format = frame::scene_color_format}),
                               TextureUse::ColorAttachment);
          },
          [gpu, push](const PassResources& res, const Step& d, PassContext& ctx) {
            const gpu::TextureView* in[] = {&res.view(d.source), &res.view(d.coarser)};
            frame::draw_fullscreen(ctx, gpu->up, "bloom_up", res.view(d.target), in, gpu->sampler, nullptr,
                                   std::as_bytes(std::span(&push, 1)));
          });
      up = step.target;
    }
    const CombinePush push{texel_of(1), radius_, intensity_, 1.0f / float(levels)};
    auto& combine = graph.add_pass<Step>(
        name,
        [&](PassBuilder& b, Step& d) {
          d.source = b.read(color, TextureUse::Sampled);
          d.coarser = b.read(up, TextureUse::Sampled);
          d.target = b.write(b.create_texture(name + ".color", {.format = frame::scene_color_format}),
                             TextureUse::ColorAttachment);
        },
        [gpu, push](const PassResources& res, const Step& d, PassContext& ctx) {
          const gpu::TextureView* in[] = {&res.view(d.source), &res.view(d.coarser)};
          frame::draw_fullscreen(ctx, gpu->combine, "bloom_combine", res.view(d.target), in, gpu->sampler, nullptr,
                                 std::as_bytes(std::span(&push, 1)));
        });
    slots.set_output("color", combine.target);
    return {};
  }

 private:
  float intensity_;
  std::uint32_t levels_;
  float radius_;
  std::shared_ptr<BloomGpu> gpu_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<BloomFramePass>(float(options.number("intensity")), std::uint32_t(options.integer("levels")),
                                          float(options.number("radius")));
}

}  // namespace

const pipeline::PassTypeDescriptor& bloom_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "bloom",
      .summary = "Physically based bloom of the linear HDR colour: no threshold, a chain of half-size levels "
                 "summed back up and mixed in by `intensity`; energy-conserving.",
      .doc = "docs/pipelines.md#bloom",
      .inputs = {{.name = "color", .formats = {frame::scene_color_format}, .meaning = "linear HDR radiance"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the colour with its bloom"}},
      .options = {pipeline::number_option("intensity", 0.0, 1.0, 0.04,
                                          "how much of the blurred chain replaces the colour (0: none, 1: only bloom)"),
                  pipeline::integer_option("levels", 1, 10, 6,
                                           "half-size levels in the chain (fewer on a small frame: the smaller side "
                                           "keeps 2 texels); more: a wider glow"),
                  pipeline::number_option("radius", 0.25, 4.0, 1.0, "the upsampling tent's radius in coarse texels")},
      .create = &create,
  };
  return d;
}

}  // namespace weft::passes
