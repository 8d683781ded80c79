module;
#include <algorithm>
#include <array>
#include <cstdint>
#include <expected>
#include <numeric>
#include <vector>
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
  WEFT_TRY(auto casters, device.create_bind_group_layout(
                             {.label = "shadow-casters",
                              .entries = {{0, gpu::BindingType::ReadOnlyStorageBuffer, gpu::ShaderStage::Vertex}}}));
  WEFT_TRY(auto layout, device.create_pipeline_layout({.label = "shadow", .bind_group_layouts = {&casters}}));
  WEFT_TRY(auto pipeline, device.create_render_pipeline(
        {.label = "shadow",
         .layout = &layout,
         .vertex = &vs,
         .vertex_buffers = {frame::vertex_layout()},
         .cull_mode = gpu::CullMode::None,  // thin and open meshes cast shadows from both sides
         .depth_stencil = gpu::DepthStencilState{.format = gpu::Format::Depth32Float,
                                                 .depth_bias_constant = settings.depth_bias_constant,
                                                 .depth_bias_slope = settings.depth_bias_slope}}));
  return ShadowPass(settings, std::move(casters), std::move(layout), std::move(pipeline));
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
        // Casters that share a mesh are one instanced draw (30,000 copies of one mesh: one
        // draw, not 30,000): their light-space matrices, grouped by mesh, in a buffer made
        // for this frame, which the vertex shader indexes by instance.
        std::vector<std::uint32_t> by_mesh(items.size());
        std::iota(by_mesh.begin(), by_mesh.end(), 0u);
        std::sort(by_mesh.begin(), by_mesh.end(), [&](std::uint32_t a, std::uint32_t b) {
          const auto ma = reinterpret_cast<std::uintptr_t>(items[a].mesh), mb = reinterpret_cast<std::uintptr_t>(items[b].mesh);
          return ma != mb ? ma < mb : a < b;
        });
        const gpu::BindGroup* casters = nullptr;
        if (!items.empty()) {
          auto buffer = ctx.device().create_buffer({.label = "shadow-casters", .size = items.size() * sizeof(mat4),
                                                    .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::MapWrite});
          if (!buffer) return ctx.encoder().report_error(buffer.error());
          auto bytes = buffer->mapped();
          if (!bytes) return ctx.encoder().report_error(bytes.error());
          auto* matrices = reinterpret_cast<mat4*>(bytes->data());
          for (std::size_t i = 0; i < by_mesh.size(); ++i) matrices[i] = light_view_projection * items[by_mesh[i]].model;
          const gpu::Buffer& kept = ctx.keep(std::move(*buffer));
          auto group = ctx.device().create_bind_group(
              {.label = "shadow-casters", .layout = &casters_layout_, .entries = {gpu::bind(0, kept)}});
          if (!group) return ctx.encoder().report_error(group.error());
          casters = &ctx.keep(std::move(*group));
        }
        auto pass = ctx.encoder().begin_render_pass(
            {.label = "shadow_map", .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth)}});
        pass.set_pipeline(pipeline_);
        if (casters) pass.set_bind_group(0, *casters);
        for (std::size_t first = 0; first < by_mesh.size();) {
          const frame::GpuMesh* mesh = items[by_mesh[first]].mesh;
          std::size_t end = first + 1;
          while (end < by_mesh.size() && items[by_mesh[end]].mesh == mesh) ++end;
          pass.set_vertex_buffer(0, mesh->vertices);
          pass.set_index_buffer(mesh->indices);
          pass.draw_indexed(mesh->index_count, std::uint32_t(end - first), 0, 0, std::uint32_t(first));
          first = end;
        }
        pass.end();
      });
  frame::put_scene_targets(graph.blackboard(), {.shadow_map = data.depth});
  return data.depth;
}

}  // namespace weft::passes
