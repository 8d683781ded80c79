// weft.base_pass.shadow — a depth map of every draw item seen from the key (directional) light.
// Writes the blackboard's "shadow_map"; the forward and feature passes sample it.
module;
#include <cstdint>
#include <expected>
#include <span>
#include <string_view>
export module weft.base_pass.shadow;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;
import weft.frame;

export namespace weft::passes {

struct ShadowSettings {
  std::uint32_t resolution = 2048;  // knob: shadow-map texels per side (16 .. 16384)
  float depth_bias_constant = 1.5f;
  float depth_bias_slope = 2.0f;
};

using frame::fit_light_view_projection;  // lives in weft.frame (the renderer needs it too)

class ShadowPass {
 public:
  static Result<ShadowPass> create(gpu::Device& device, const ShadowSettings& settings = {});
  // Adds the pass; `items` and `light_view_projection` must outlive the graph's execution.
  TextureHandle add(RenderGraph& graph, std::span<const frame::DrawItem> items, const mat4& light_view_projection,
                    std::string_view name = "shadow_map") const;
  [[nodiscard]] const ShadowSettings& settings() const { return settings_; }

 private:
  ShadowSettings settings_;
  gpu::BindGroupLayout casters_layout_;  // the casters' light-space matrices (a storage buffer)
  gpu::PipelineLayout layout_;
  gpu::RenderPipeline pipeline_;
  ShadowPass(ShadowSettings s, gpu::BindGroupLayout c, gpu::PipelineLayout l, gpu::RenderPipeline p)
      : settings_(s), casters_layout_(std::move(c)), layout_(std::move(l)), pipeline_(std::move(p)) {}
};

// The pass type of the key light's depth map (pass_type.cpp); weft::register_builtins() registers it.
const pipeline::PassTypeDescriptor& shadow_map_pass_type();

}  // namespace weft::passes
