// SkinSSSPass: the graph pass (pipeline, bind groups, the draw loop inside
// frame::add_scene_color_pass).
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>
#include <nlohmann/json.hpp>
#include <weft/try.h>
#include "weft_pass_skin_sss_shaders.h"
module weft.pass.skin_sss;

namespace weft::passes {

namespace {

// Matches `Draw` in skin_common.glsl.
struct SkinConstants {
  mat4 model;
  vec4 albedo_specular;
  vec4 params;
  vec4 normal_blur;
  vec4 transmit;
};
static_assert(sizeof(SkinConstants) == 128);

enum : int { flag_albedo_map = 1, flag_normal_map = 2, flag_screen_curvature = 4, flag_reference = 8, flag_specular_map = 16 };
constexpr int debug_view_shift = 32;  // transmit.z = flags + 32 * debug view (skin_common.glsl)
}  // namespace

struct SkinSSSPass::State {
  gpu::BindGroupLayout frame_layout;
  gpu::BindGroupLayout material_layout;
  gpu::BindGroupLayout reference_layout;
  gpu::Buffer no_reference;  // bound when a draw uses the LUT
  std::shared_ptr<const gpu::PipelineLayout> layout;
  frame::PipelineSamples pipeline;
  gpu::Sampler shadow_compare;
  gpu::Sampler shadow_depth;
  gpu::Sampler environment;
  gpu::Sampler lut;
  gpu::Sampler texture;
};

Result<SkinSSSPass> SkinSSSPass::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  WEFT_TRY(auto vs, device.create_shader_module({.label = "skin.vert", .stage = ShaderStage::Vertex, .spirv = shaders::skin_vert()}));
  WEFT_TRY(auto fs, device.create_shader_module({.label = "skin.frag", .stage = ShaderStage::Fragment, .spirv = shaders::skin_frag()}));
  WEFT_TRY(auto frame_layout,
           device.create_bind_group_layout({.label = "skin-frame",
                                            .entries = {{0, BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                                                        {1, BindingType::TextureSampler, ShaderStage::Fragment},
                                                        {2, BindingType::TextureSampler, ShaderStage::Fragment},
                                                        {3, BindingType::TextureSampler, ShaderStage::Fragment}}}));
  WEFT_TRY(auto material_layout,
           device.create_bind_group_layout({.label = "skin-material",
                                            .entries = {{0, BindingType::TextureSampler, ShaderStage::Fragment},
                                                        {1, BindingType::TextureSampler, ShaderStage::Fragment},
                                                        {2, BindingType::TextureSampler, ShaderStage::Fragment},
                                                        {3, BindingType::TextureSampler, ShaderStage::Fragment}}}));
  WEFT_TRY(auto reference_layout,
           device.create_bind_group_layout(
               {.label = "skin-reference", .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex}}}));
  const vec4 zero(0.0f);
  WEFT_TRY(auto no_reference,
           device.create_buffer_with_data({.label = "skin-no-reference", .size = sizeof(zero),
                                           .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
                                          std::as_bytes(std::span(&zero, 1))));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout({.label = "skin",
                                                       .bind_group_layouts = {&frame_layout, &material_layout, &reference_layout},
                                                       .push_constant_size = sizeof(SkinConstants)}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  WEFT_TRY(auto pipeline, frame::create_lit_mesh_pipelines(device, "skin", layout, std::move(vs), std::move(fs)));
  WEFT_TRY(auto shadow_compare, frame::create_shadow_compare_sampler(device, "skin-shadow-compare"));
  WEFT_TRY(auto shadow_depth, device.create_sampler({.label = "skin-shadow-depth", .mag_filter = gpu::FilterMode::Nearest,
                                                     .min_filter = gpu::FilterMode::Nearest,
                                                     .mipmap_filter = gpu::FilterMode::Nearest, .max_lod = 0.0f}));
  WEFT_TRY(auto environment, device.create_sampler({.label = "skin-environment", .address_mode = gpu::AddressMode::Repeat}));
  WEFT_TRY(auto lut, device.create_sampler({.label = "skin-lut", .mipmap_filter = gpu::FilterMode::Nearest, .max_lod = 0.0f}));
  WEFT_TRY(auto texture, device.create_sampler({.label = "skin-texture", .address_mode = gpu::AddressMode::Repeat,
                                                .max_anisotropy = 16.0f}));
  SkinSSSPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(frame_layout), std::move(material_layout), std::move(reference_layout),
                                              std::move(no_reference), layout, std::move(pipeline),
                                              std::move(shadow_compare), std::move(shadow_depth), std::move(environment),
                                              std::move(lut), std::move(texture)});
  return pass;
}

Result<std::shared_ptr<SkinGpuMaterial>> SkinSSSPass::create_material(gpu::Device& device, const skin::SkinMaterial& material,
                                                                      const gpu::Texture& lut, const gpu::Texture& albedo,
                                                                      const gpu::Texture& normal,
                                                                      const gpu::Texture& specular) const {
  WEFT_TRY(auto group, device.create_bind_group({.label = "skin-material",
                                           .layout = &state_->material_layout,
                                           .entries = {gpu::bind(0, lut.view(), &state_->lut),
                                                       gpu::bind(1, albedo.view(), &state_->texture),
                                                       gpu::bind(2, normal.view(), &state_->texture),
                                                       gpu::bind(3, specular.view(), &state_->texture)}}));
  auto out = std::make_shared<SkinGpuMaterial>(SkinGpuMaterial{material, std::move(group), 0});
  if (!material.albedo_texture.empty()) out->flags |= flag_albedo_map;
  if (!material.normal_texture.empty()) out->flags |= flag_normal_map;
  if (!material.specular_texture.empty()) out->flags |= flag_specular_map;
  if (material.curvature == skin::CurvatureSource::Screen) out->flags |= flag_screen_curvature;
  return out;
}

Result<void> SkinSSSPass::add(RenderGraph& graph, std::span<const SkinDraw> draws,
                              std::span<const std::shared_ptr<SkinGpuMaterial>> materials,
                              std::span<const gpu::Texture* const> luts) const {
  for (const auto& d : draws)
    if (!d.mesh || d.material >= materials.size() || !materials[d.material])
      return fail(ErrorKind::InvalidArgument, "skin pass: a draw names material {} of {} (or has no mesh)", d.material,
                  materials.size());
  frame::ScenePassDesc desc{.name = "skin_sss", .reads_environment = true};
  for (std::size_t i = 0; i < luts.size(); ++i)
    desc.textures.push_back({luts.size() == 1 ? std::string("skin_lut") : weft::format("skin_lut_{}", i), luts[i]});
  // The reference mode's per-draw buffers (null for LUT draws: skipped).
  for (std::size_t i = 0; i < draws.size(); ++i) desc.buffers.push_back({weft::format("skin_reference_{}", i), draws[i].reference});
  auto state = state_;
  return frame::add_scene_color_pass(graph, std::move(desc), [state, draws, materials](frame::ScenePassDraw& scene) {
    PassContext& ctx = scene.context;
    auto group = ctx.device().create_bind_group(
        {.label = "skin-frame",
         .layout = &state->frame_layout,
         .entries = {gpu::bind(0, scene.uniforms), gpu::bind(1, scene.shadow_map, &state->shadow_compare),
                     gpu::bind(2, scene.shadow_map, &state->shadow_depth),
                     gpu::bind(3, *scene.environment, &state->environment)}});
    if (!group) return ctx.encoder().report_error(group.error());
    const auto& frame_group = ctx.keep(std::move(*group));
    // The per-draw reference buffers (the reference mode), or a dummy for LUT draws.
    auto none = ctx.device().create_bind_group(
        {.label = "skin-no-reference", .layout = &state->reference_layout, .entries = {gpu::bind(0, state->no_reference)}});
    if (!none) return ctx.encoder().report_error(none.error());
    std::vector<const gpu::BindGroup*> reference_groups(draws.size(), &ctx.keep(std::move(*none)));
    for (std::size_t i = 0; i < draws.size(); ++i) {
      if (!draws[i].reference) continue;
      auto reference = ctx.device().create_bind_group({.label = "skin-reference",
                                                       .layout = &state->reference_layout,
                                                       .entries = {gpu::bind(0, *draws[i].reference)}});
      if (!reference) return ctx.encoder().report_error(reference.error());
      reference_groups[i] = &ctx.keep(std::move(*reference));
    }
    auto pipeline = state->pipeline.at(ctx.device(), scene.samples);
    if (!pipeline) return ctx.encoder().report_error(pipeline.error());
    gpu::RenderPassEncoder& pass = scene.pass;
    pass.set_pipeline(**pipeline);
    pass.set_bind_group(0, frame_group);
    for (std::size_t i = 0; i < draws.size(); ++i) {
      const SkinDraw& draw = draws[i];
      const SkinGpuMaterial& mat = *materials[draw.material];
      const int flags = mat.flags | (draw.reference ? flag_reference : 0);
      pass.set_bind_group(2, *reference_groups[i]);
      const skin::SkinMaterial& m = mat.params;
      // Uniform scale of the object (curvature is per mesh unit; mm_per_unit is per world unit).
      const float scale = std::cbrt(std::abs(glm::determinant(mat3(draw.model))));
      const float to_lut = m.curvature_scale / (m.mm_per_unit * float(m.lut.max_curvature));  // world 1/r -> v
      SkinConstants c{};
      c.model = draw.model;
      c.albedo_specular = vec4(m.albedo, m.specular);
      c.params = vec4(m.roughness, scale > 0.0f && std::isfinite(scale) ? 1.0f / scale : 0.0f, to_lut, m.mm_per_unit);
      c.normal_blur = vec4(m.normal_blur, m.normal_strength);
      c.transmit = vec4(m.transmittance ? m.transmittance_scale : 0.0f, m.transmittance_shrink_mm / m.mm_per_unit,
                        float(flags + debug_view_shift * int(m.debug_view)), m.shadow_scatter_mm / m.mm_per_unit);
      pass.set_bind_group(1, mat.group);
      pass.push(c);
      pass.set_vertex_buffer(0, draw.mesh->vertices);
      pass.set_index_buffer(draw.mesh->indices);
      pass.draw_indexed(draw.mesh->index_count);
    }
  });
}

}  // namespace weft::passes
