// weft.base_pass.shadow — a depth map of every draw item seen from the key (directional) light.
// Writes the blackboard's "shadow_map"; the forward and feature passes sample it.
module;
#include <cstdint>
#include <expected>
#include <span>
export module weft.base_pass.shadow;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;

export namespace weft::passes {

struct ShadowSettings {
  std::uint32_t resolution = 2048;  // knob: shadow-map texels per side (16 .. 16384)
  float depth_bias_constant = 1.5f;
  float depth_bias_slope = 2.0f;
};

// Orthographic light matrix enclosing the box [lo, hi] seen along `towards_light`.
mat4 fit_light_view_projection(vec3 towards_light, vec3 lo, vec3 hi);

class ShadowPass {
 public:
  static Result<ShadowPass> create(gpu::Device& device, const ShadowSettings& settings = {});
  // Adds the pass; `items` and `light_view_projection` must outlive the graph's execution.
  TextureHandle add(RenderGraph& graph, std::span<const frame::DrawItem> items, const mat4& light_view_projection) const;
  [[nodiscard]] const ShadowSettings& settings() const { return settings_; }

 private:
  ShadowSettings settings_;
  gpu::PipelineLayout layout_;
  gpu::RenderPipeline pipeline_;
  ShadowPass(ShadowSettings s, gpu::PipelineLayout l, gpu::RenderPipeline p)
      : settings_(s), layout_(std::move(l)), pipeline_(std::move(p)) {}
};

}  // namespace weft::passes
