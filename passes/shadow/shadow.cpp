module;
#include <algorithm>
#include <array>
#include <cstdint>
#include <expected>
#include <span>
#include <string_view>
#include <glm/gtc/matrix_transform.hpp>
#include "weft_pass_shadow_shaders.h"
#include <weft/try.h>
module weft.base_pass.shadow;

namespace weft::passes {

Result<ShadowPass> ShadowPass::create(gpu::Device& device, const ShadowSettings& settings) {
  if (settings.resolution < 16 || settings.resolution > device.adapter_info().limits.max_texture_dimension_2d)
    return fail(ErrorKind::InvalidArgument, "shadow pass: resolution {} outside [16, {}]", settings.resolution,
                device.adapter_info().limits.max_texture_dimension_2d);
  WEFT_TRY(auto vs, device.create_shader_module({.label = "shadow.vert", .stage = gpu::ShaderStage::Vertex, .spirv = shaders::shadow_vert()}));
  WEFT_TRY(auto layout, device.create_pipeline_layout({.label = "shadow", .push_constant_size = sizeof(mat4)}));
  WEFT_TRY(auto pipeline, device.create_render_pipeline(
        {.label = "shadow",
         .layout = &layout,
         .vertex = &vs,
         .vertex_buffers = {frame::vertex_layout()},
         .cull_mode = gpu::CullMode::None,  // thin and open meshes cast shadows from both sides
         .depth_stencil = gpu::DepthStencilState{.format = gpu::Format::Depth32Float,
                                                 .depth_bias_constant = settings.depth_bias_constant,
                                                 .depth_bias_slope = settings.depth_bias_slope}}));
  return ShadowPass(settings, std::move(layout), std::move(pipeline));
}

TextureHandle ShadowPass::add(RenderGraph& graph, std::span<const frame::DrawItem> items,
                              const mat4& light_view_projection, std::string_view name) const {
  struct Data {
    TextureHandle depth;
  };
  const std::uint32_t n = settings_.resolution;
  auto& data = graph.add_pass<Data>(
      name,
      [&](PassBuilder& b, Data& d) {
        d.depth = b.create_texture("shadow_map", {.size = gpu::Extent3D{n, n, 1}, .format = gpu::Format::Depth32Float});
        d.depth = b.write(d.depth, TextureUse::DepthAttachment);
      },
      [this, items, light_view_projection](const PassResources& res, const Data& d, PassContext& ctx) {
        auto pass = ctx.encoder().begin_render_pass(
            {.label = "shadow_map", .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth)}});
        pass.set_pipeline(pipeline_);
        for (const auto& item : items) {
          pass.push(light_view_projection * item.model);
          pass.set_vertex_buffer(0, item.mesh->vertices);
          pass.set_index_buffer(item.mesh->indices);
          pass.draw_indexed(item.mesh->index_count);
        }
        pass.end();
      });
  frame::put_scene_targets(graph.blackboard(), {.shadow_map = data.depth});
  return data.depth;
}

}  // namespace weft::passes
