module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <vector>
#include "weft_pass_forward_shaders.h"
module weft.base_pass.forward;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;

namespace weft::passes {

struct ForwardPass::State {
  gpu::BindGroupLayout bind_layout;
  gpu::BindGroupLayout material_layout;
  gpu::Texture white;  // the base colour map of materials without one
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
  gpu::Sampler shadow_sampler;
  gpu::Sampler environment_sampler;
  gpu::Sampler material_sampler;
};

namespace {
struct DrawConstants {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
};
}  // namespace

Result<ForwardPass> ForwardPass::create(gpu::Device& device) {
  auto vs = device.create_shader_module({.label = "forward.vert", .stage = gpu::ShaderStage::Vertex, .spirv = shaders::forward_vert()});
  if (!vs) return std::unexpected(vs.error());
  auto fs = device.create_shader_module({.label = "forward.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::forward_frag()});
  if (!fs) return std::unexpected(fs.error());
  auto bind_layout = device.create_bind_group_layout(
      {.label = "forward",
       .entries = {{0, gpu::BindingType::UniformBuffer, gpu::ShaderStage::Vertex | gpu::ShaderStage::Fragment},
                   {1, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                   {2, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  if (!bind_layout) return std::unexpected(bind_layout.error());
  auto material_layout = device.create_bind_group_layout(
      {.label = "forward-material", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  if (!material_layout) return std::unexpected(material_layout.error());
  auto white = device.create_texture({.label = "white", .size = {1, 1, 1}, .format = gpu::Format::RGBA8Unorm,
                                      .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!white) return std::unexpected(white.error());
  const std::uint8_t white_texel[4] = {255, 255, 255, 255};
  if (auto ok = device.queue().write_texture(*white, std::as_bytes(std::span(white_texel))); !ok)
    return std::unexpected(ok.error());
  auto layout = device.create_pipeline_layout({.label = "forward",
                                               .bind_group_layouts = {&*bind_layout, &*material_layout},
                                               .push_constant_size = sizeof(DrawConstants)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = frame::create_lit_mesh_pipeline(device, "forward", *layout, *vs, *fs, scene_color_format,
                                                  scene_depth_format);
  if (!pipeline) return std::unexpected(pipeline.error());
  auto shadow_sampler = frame::create_shadow_compare_sampler(device, "shadow-compare");
  if (!shadow_sampler) return std::unexpected(shadow_sampler.error());
  auto environment_sampler = device.create_sampler({.label = "environment", .address_mode = gpu::AddressMode::Repeat});
  if (!environment_sampler) return std::unexpected(environment_sampler.error());
  auto material_sampler = device.create_sampler({.label = "material", .address_mode = gpu::AddressMode::Repeat});
  if (!material_sampler) return std::unexpected(material_sampler.error());
  ForwardPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(*bind_layout), std::move(*material_layout), std::move(*white),
                                              std::move(*layout), std::move(*pipeline),
                                              std::move(*shadow_sampler), std::move(*environment_sampler),
                                              std::move(*material_sampler)});
  return pass;
}

Result<void> ForwardPass::add(RenderGraph& graph, std::span<const frame::DrawItem> items, vec4 clear_color) const {
  auto state = state_;
  return frame::add_scene_color_pass(
      graph, {.name = "forward", .reads_environment = true, .clear_color = clear_color},
      [state, items](frame::ScenePassDraw& draw) {
        PassContext& ctx = draw.context;
        auto group = ctx.device().create_bind_group(
            {.label = "forward",
             .layout = &state->bind_layout,
             .entries = {gpu::bind(0, draw.uniforms), gpu::bind(1, draw.shadow_map, &state->shadow_sampler),
                         gpu::bind(2, *draw.environment, &state->environment_sampler)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));  // alive until the frame is done
        gpu::RenderPassEncoder& pass = draw.pass;
        pass.set_pipeline(state->pipeline);
        pass.set_bind_group(0, frame_group);
        // One material bind group per distinct base colour map (textures are imported
        // read-only assets, already in ShaderRead state).
        std::vector<std::pair<const gpu::TextureView*, const gpu::BindGroup*>> material_groups;
        auto material_group = [&](const gpu::TextureView* view) -> const gpu::BindGroup* {
          if (!view) view = &state->white.view();
          for (auto& [v, g] : material_groups)
            if (v == view) return g;
          auto g = ctx.device().create_bind_group({.label = "forward-material", .layout = &state->material_layout,
                                                   .entries = {gpu::bind(0, *view, &state->material_sampler)}});
          if (!g) {
            ctx.encoder().report_error(g.error());
            return nullptr;
          }
          material_groups.emplace_back(view, &ctx.keep(std::move(*g)));
          return material_groups.back().second;
        };
        for (const auto& item : items) {
          const auto* item_group = material_group(item.base_color_texture);
          if (!item_group) break;
          pass.set_bind_group(1, *item_group);
          const auto& m = item.material;
          pass.push(DrawConstants{item.model, vec4(m.base_color, m.metallic), vec4(m.roughness, m.emissive)});
          pass.set_vertex_buffer(0, item.mesh->vertices);
          pass.set_index_buffer(item.mesh->indices);
          pass.draw_indexed(item.mesh->index_count);
        }
      });
}

}  // namespace weft::passes
