// The taa pass type: the history of a moving camera's jittered frames, reprojected through the
// depth and blended in (taa.frag), kept between frames in two textures (read one, write the
// other) with the last frame's camera.
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
#include <glm/glm.hpp>
#include <weft/try.h>
#include "weft_pass_taa_shaders.h"
module weft.base_pass.taa;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.pipeline;

namespace weft::passes {
namespace {

struct Push {
  mat4 reprojection;
  vec2 jitter_uv;
  float alpha;
  std::uint32_t flags;
};
static_assert(sizeof(Push) == 80);
constexpr std::uint32_t display_encoded = 1, neighbourhood_clamp = 2;
constexpr gpu::Format history_format = gpu::Format::RGBA16Float;

class TaaFramePass final : public pipeline::FramePass {
 public:
  TaaFramePass(float blend, bool clamp) : blend_(blend), clamp_(clamp) {}

  Result<void> prepare(gpu::Device& device, const pipeline::PassFrame&) override {
    if (gpu_) return {};
    WEFT_TRY(gpu_, frame::TemporalPipelines::create(device, "taa", shaders::taa_frag(), 3,
                                                   sizeof(Push)));
    device_ = &device;
    return {};
  }

  Result<void> add(RenderGraph& graph, const pipeline::PassFrame& frame, pipeline::PassSlots& slots) override {
    const std::string name(slots.pass_name());
    if (!gpu_) return fail(ErrorKind::Internal, "pass '{}': add() before prepare()", name);
    const TextureHandle color = slots.input("color"), depth = slots.input("depth");
    const auto desc = graph.texture_desc(color);
    if (!desc || !gpu_->writes(desc->format))
      return fail(ErrorKind::Unsupported, "pass '{}': input 'color' must be rgba8unorm or rgba16float", name);
    const gpu::Extent3D size = desc->size.resolve({frame.width, frame.height, 1});
    WEFT_TRY(const bool fresh, history_.ensure(*device_, name, size, history_format));
    if (fresh) frames_ = 0;
    // The camera without this frame's jitter, now and a frame ago: the reprojection moves a
    // pixel from where the scene is to where it was.
    const mat4 projection = frame::jitter_projection(frame.uniforms.projection, -frame.jitter, size.width, size.height);
    const mat4 view_projection = projection * frame.uniforms.view;
    const bool has_history = frames_ > 0 && last_view_projection_;
    Push push{.reprojection = has_history ? *last_view_projection_ * glm::inverse(view_projection) : mat4(1.0f),
              .jitter_uv = frame.jitter / vec2(float(size.width), float(size.height)),
              // The first frames average evenly (a still start converges like accumulation),
              // then each new frame weighs `blend`.
              .alpha = has_history ? std::max(blend_, 1.0f / float(frames_ + 1)) : 1.0f,
              .flags = (desc->format == gpu::Format::RGBA8Unorm ? display_encoded : 0u) | (clamp_ ? neighbourhood_clamp : 0u)};
    const auto bytes = std::as_bytes(std::span(&push, 1));
    const std::vector<std::byte> push_bytes(bytes.begin(), bytes.end());

    const auto [history, next] = history_.import(graph, name, has_history);
    WEFT_TRY(const TextureHandle blended,
             frame::add_fullscreen_pass(graph, {.name = name, .inputs = {color, depth, history}, .target = next,
                                                .format = history_format, .push = push_bytes},
                                        gpu_->blend, gpu_->sampler, gpu_));
    graph.mark_output(blended, gpu::Access::ShaderRead);
    WEFT_TRY(const TextureHandle out, gpu_->add_output(graph, name + ".output", blended, slots.target("color"), desc->format, gpu_));
    slots.set_output("color", out);
    ++frames_;
    last_view_projection_ = view_projection;
    return {};
  }

 private:
  float blend_;
  bool clamp_;
  std::shared_ptr<const frame::TemporalPipelines> gpu_;
  gpu::Device* device_ = nullptr;
  frame::HistoryTextures history_;
  std::uint32_t frames_ = 0;  // frames in the history
  std::optional<mat4> last_view_projection_;
};

Result<std::unique_ptr<pipeline::FramePass>> create(const pipeline::PassOptions& options) {
  return std::make_unique<TaaFramePass>(float(options.number("blend")), options.boolean("clamp"));
}

}  // namespace

const pipeline::PassTypeDescriptor& taa_pass_type() {
  static const pipeline::PassTypeDescriptor d{
      .name = "taa",
      .summary = "Temporal anti-aliasing for a moving camera: the jittered frames' history reprojected through the "
                 "depth to where the camera saw it last frame, clamped to the current 3x3 neighbourhood and blended in.",
      .doc = "docs/pipelines.md#taa",
      .inputs = {{.name = "color", .formats = {gpu::Format::RGBA8Unorm, frame::scene_color_format},
                  .meaning = "the colour (display-encoded colour is blended as light)"},
                 {.name = "depth", .formats = {frame::scene_depth_format}, .meaning = "the camera's depth (reprojects the history)"}},
      .outputs = {{.name = "color", .same_as = "color", .meaning = "the colour with its history blended in"}},
      .options = {pipeline::number_option("blend", 0.02, 1.0, 0.1,
                                          "the weight of each new frame once the history is full (smaller: smoother, "
                                          "slower to follow; 1: no history)",
                                          {0.25, 0.1, 0.05}),
                  pipeline::boolean_option("clamp", true,
                                           "clamp the history to the current 3x3 neighbourhood (no ghosting where the "
                                           "view changed; off: a still view converges further)")},
      .create = &create,
      .temporal = true,
  };
  return d;
}

}  // namespace weft::passes
