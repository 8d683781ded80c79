// ToonPass: two pipelines (surface, outline) and the draw loop; weft.frame's
// add_scene_color_pass finds the frame's targets, declares the reads and attachments and
// puts the new colour and depth back.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <utility>
#include <weft/try.h>
#include "custom_toon_shaders.h"
module custom.toon;

namespace custom {

using namespace weft;

namespace {
struct ToonPush {  // Draw in shaders/toon_common.glsl
  mat4 model;
  vec4 base_color_bands;
  vec4 outline_color_width;
  vec4 options;
};
static_assert(sizeof(ToonPush) == 112);
}  // namespace

struct ToonPass::State {
  gpu::BindGroupLayout bind_layout;
  std::shared_ptr<const gpu::PipelineLayout> layout;
  frame::PipelineSamples surface, outline;  // in each sample count the frame draws with (MSAA)
  gpu::Sampler shadow;
};

Result<ToonPass> ToonPass::create(gpu::Device& device) {
  using gpu::ShaderStage;
  auto shader = [&](const char* label, ShaderStage stage, std::span<const std::uint32_t> spirv) {
    return device.create_shader_module({.label = label, .stage = stage, .spirv = spirv});
  };
  WEFT_TRY(auto surface_vs, shader("toon.vert", ShaderStage::Vertex, shaders::toon_vert()));
  WEFT_TRY(auto surface_fs, shader("toon.frag", ShaderStage::Fragment, shaders::toon_frag()));
  WEFT_TRY(auto outline_vs, shader("outline.vert", ShaderStage::Vertex, shaders::outline_vert()));
  WEFT_TRY(auto outline_fs, shader("outline.frag", ShaderStage::Fragment, shaders::outline_frag()));
  WEFT_TRY(auto bind_layout,
           device.create_bind_group_layout(
               {.label = "toon",
                .entries = {{0, gpu::BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                            {1, gpu::BindingType::TextureSampler, ShaderStage::Fragment}}}));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout(
                            {.label = "toon", .bind_group_layouts = {&bind_layout}, .push_constant_size = sizeof(ToonPush)}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  WEFT_TRY(auto surface, frame::create_lit_mesh_pipelines(device, "toon.surface", layout, std::move(surface_vs),
                                                          std::move(surface_fs)));
  // The hull keeps only its back faces, which lie behind the surface except at the rim.
  WEFT_TRY(auto outline, frame::PipelineSamples::create(device, layout,
                                                         {.label = "toon.outline",
                                                          .layout = layout.get(),
                                                          .vertex_buffers = {frame::vertex_layout()},
                                                          .cull_mode = gpu::CullMode::Front,
                                                          .color_targets = {{frame::scene_color_format}},
                                                          .depth_stencil = gpu::DepthStencilState{
                                                              .format = frame::scene_depth_format}},
                                                         std::move(outline_vs), std::move(outline_fs)));
  WEFT_TRY(auto shadow, frame::create_shadow_compare_sampler(device, "toon.shadow"));
  ToonPass pass;
  pass.state_ = std::make_shared<State>(
      State{std::move(bind_layout), layout, std::move(surface), std::move(outline), std::move(shadow)});
  return pass;
}

Result<void> ToonPass::add(RenderGraph& graph, std::span<const ToonDraw> draws) const {
  if (draws.empty()) return {};
  for (std::size_t i = 0; i < draws.size(); ++i)
    if (!draws[i].mesh) return fail(ErrorKind::InvalidArgument, "toon: draw {} has no mesh", i);
  auto state = state_;
  return frame::add_scene_color_pass(graph, {.name = "toon"}, [state, draws](frame::ScenePassDraw& scene) {
    auto group = scene.context.device().create_bind_group(
        {.label = "toon",
         .layout = &state->bind_layout,
         .entries = {gpu::bind(0, scene.uniforms), gpu::bind(1, scene.shadow_map, &state->shadow)}});
    if (!group) return scene.context.encoder().report_error(group.error());
    const gpu::BindGroup& frame_group = scene.context.keep(std::move(*group));
    gpu::RenderPassEncoder& pass = scene.pass;
    for (const frame::PipelineSamples* set : {&state->surface, &state->outline}) {
      auto pipeline = set->at(scene.context.device(), scene.samples);
      if (!pipeline) return scene.context.encoder().report_error(pipeline.error());
      pass.set_pipeline(**pipeline);
      pass.set_bind_group(0, frame_group);
      for (const ToonDraw& draw : draws) {
        const ToonMaterial& m = draw.material;
        if (set == &state->outline && !(m.outline_width > 0.0f)) continue;
        pass.push(ToonPush{draw.model, vec4(m.base_color, float(m.bands)), vec4(m.outline_color, m.outline_width),
                           vec4(m.shadows ? 1.0f : 0.0f, 0.0f, 0.0f, 0.0f)});
        pass.set_vertex_buffer(0, draw.mesh->vertices);
        pass.set_index_buffer(draw.mesh->indices);
        pass.draw_indexed(draw.mesh->index_count);
      }
    }
  });
}

}  // namespace custom
