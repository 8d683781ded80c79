// SSDFLightingPass: the uploads (SSDF asset, lobes, the irradiance table) and the render
// pass that draws "ssdf" objects over what the forward pass drew.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include "weft_pass_ssdf_lighting_shaders.h"
#include <weft/try.h>
module weft.pass.ssdf_lighting;
import weft.cluster;

namespace weft::passes {

namespace {

constexpr std::uint32_t kNoMean = 0xffffffffu;

// The push constants of ssdf_common.glsl.
struct SsdfPush {
  mat4 model;
  vec4 albedo_mode;    // rgb albedo, w: 1 = per-pixel shading
  glm::uvec4 info;          // x base vertex, y lobe count, z directions, w unused
  vec4 params;         // x half the grid spacing (radians)
};
static_assert(sizeof(SsdfPush) == 112);

// std430 lobe of ssdf_common.glsl.
struct GpuLobe {
  vec4 axis_sharpness;
  vec4 energy_width;  // rgb: ∫ G dω, w: unused (the width is derived in the shader)
  glm::uvec4 cells;
  vec4 weights;
};
static_assert(sizeof(GpuLobe) == 64);

Result<gpu::Buffer> storage(gpu::Device& device, std::string label, std::span<const std::byte> bytes) {
  // Vulkan buffers may not be empty.
  static const std::byte zero[16] = {};
  if (bytes.empty()) bytes = zero;
  return device.create_buffer_with_data({.label = std::move(label), .usage = gpu::BufferUsage::Storage}, bytes);
}

}  // namespace

Result<SsdfGpuAsset> upload_ssdf(gpu::Device& device, const ssdf::Asset& asset, std::string_view label) {
  const cluster::Cpca& cpca = asset.cpca;
  const std::size_t directions = std::size_t(asset.resolution) * asset.resolution;
  if (cpca.cols != directions || cpca.cluster_of.size() != cpca.row_count || cpca.slot_of.size() != cpca.row_count)
    return fail(ErrorKind::InvalidArgument, "SSDF upload '{}': the asset's sizes disagree ({} directions, {} columns)",
                label, directions, cpca.cols);
  std::vector<uvec2> vertex_table(cpca.row_count);
  for (std::size_t v = 0; v < cpca.row_count; ++v) vertex_table[v] = uvec2(cpca.cluster_of[v], cpca.slot_of[v]);
  std::vector<glm::uvec4> cluster_table;
  std::vector<float> data;
  for (const auto& c : cpca.clusters) {
    const auto m = std::uint32_t(c.basis.rows);
    glm::uvec4 info(m, 0, 0, kNoMean);
    if (!c.mean.empty()) {
      info.w = std::uint32_t(data.size());
      data.insert(data.end(), c.mean.begin(), c.mean.end());
    }
    info.z = std::uint32_t(data.size());
    data.insert(data.end(), c.basis.values.begin(), c.basis.values.end());
    info.y = std::uint32_t(data.size());
    // Coefficients as a decoder sees them (8-bit ones already dequantised by cluster::compress).
    data.insert(data.end(), c.coefficients.values.begin(), c.coefficients.values.end());
    cluster_table.push_back(info);
  }
  if (data.size() >= 0xffffffffu)
    return fail(ErrorKind::InvalidArgument, "SSDF upload '{}': {} values do not fit 32-bit offsets", label, data.size());
  WEFT_TRY(auto vertices, storage(device, std::string(label) + ".vertex_table", std::as_bytes(std::span(vertex_table))));
  WEFT_TRY(auto clusters, storage(device, std::string(label) + ".cluster_table", std::as_bytes(std::span(cluster_table))));
  WEFT_TRY(auto values, storage(device, std::string(label) + ".data", std::as_bytes(std::span(data))));
  SsdfGpuAsset gpu_asset{std::move(vertices), std::move(clusters), std::move(values), asset.resolution,
                         std::uint32_t(directions), std::uint32_t(cpca.row_count), 0};
  gpu_asset.bytes = vertex_table.size() * sizeof(uvec2) + cluster_table.size() * sizeof(glm::uvec4) + data.size() * 4;
  return gpu_asset;
}

Result<SsdfGpuLobes> upload_lobes(gpu::Device& device, std::span<const ssdf::SphericalGaussian> lobes,
                                  std::uint32_t resolution, std::string_view label) {
  if (lobes.empty() || lobes.size() > ssdf::max_lobes)
    return fail(ErrorKind::InvalidArgument, "SSDF lobes '{}': {} lobes; 1 .. {} are supported", label, lobes.size(),
                ssdf::max_lobes);
  const ssdf::DirectionGrid grid(resolution);
  std::vector<GpuLobe> gpu_lobes;
  for (const auto& lobe : lobes) {
    const auto taps = grid.bilinear(lobe.axis);
    gpu_lobes.push_back({vec4(lobe.axis, lobe.sharpness), vec4(ssdf::energy(lobe), 0.0f),
                         glm::uvec4(taps.cells[0], taps.cells[1], taps.cells[2], taps.cells[3]),
                         vec4(taps.weights[0], taps.weights[1], taps.weights[2], taps.weights[3])});
  }
  WEFT_TRY(auto buffer, storage(device, std::string(label), std::as_bytes(std::span(gpu_lobes))));
  return SsdfGpuLobes{std::move(buffer), std::uint32_t(lobes.size()), resolution};
}

struct SSDFLightingPass::State {
  gpu::BindGroupLayout bind_layout;
  std::shared_ptr<const gpu::PipelineLayout> layout;
  frame::PipelineSamples pipeline;
  gpu::Sampler shadow;
  gpu::Buffer table;  // ssdf::irradiance_table()
};

Result<SSDFLightingPass> SSDFLightingPass::create(gpu::Device& device) {
  WEFT_TRY(auto vs, device.create_shader_module(
        {.label = "ssdf_lighting/ssdf.vert", .stage = gpu::ShaderStage::Vertex, .spirv = shaders::ssdf_vert()}));
  WEFT_TRY(auto fs, device.create_shader_module(
        {.label = "ssdf_lighting/ssdf.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::ssdf_frag()}));
  using gpu::BindingType;
  using gpu::ShaderStage;
  const auto both = ShaderStage::Vertex | ShaderStage::Fragment;
  WEFT_TRY(auto bind_layout, device.create_bind_group_layout(
        {.label = "ssdf_lighting",
         .entries = {{0, BindingType::UniformBuffer, both},
                     {1, BindingType::TextureSampler, ShaderStage::Fragment},
                     {2, BindingType::ReadOnlyStorageBuffer, both},
                     {3, BindingType::ReadOnlyStorageBuffer, both},
                     {4, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex},
                     {5, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex},
                     {6, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex}}}));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout(
        {.label = "ssdf_lighting", .bind_group_layouts = {&bind_layout}, .push_constant_size = sizeof(SsdfPush)}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  WEFT_TRY(auto pipeline, frame::create_lit_mesh_pipelines(device, "ssdf_lighting", layout, std::move(vs), std::move(fs)));
  WEFT_TRY(auto shadow, frame::create_shadow_compare_sampler(device, "ssdf.shadow"));
  // The table is a second of quadrature the first time: a declaring device (a frame declared,
  // never drawn) gets the buffer at its size without it.
  constexpr std::uint64_t table_bytes = std::uint64_t(ssdf::IrradianceTable::rows) * ssdf::IrradianceTable::columns * sizeof(float);
  WEFT_TRY(auto table, device.declaring()
                           ? device.create_buffer({.label = "ssdf.irradiance_table", .size = table_bytes,
                                                   .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst})
                           : storage(device, "ssdf.irradiance_table",
                                     std::as_bytes(std::span(ssdf::irradiance_table().values))));
  SSDFLightingPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(bind_layout), layout, std::move(pipeline),
                                              std::move(shadow), std::move(table)});
  return pass;
}

Result<void> SSDFLightingPass::add(RenderGraph& graph, std::span<const SsdfDraw> draws) const {
  if (draws.empty()) return {};
  for (std::size_t i = 0; i < draws.size(); ++i) {
    const SsdfDraw& d = draws[i];
    if (!d.mesh || !d.asset || !d.lobes)
      return fail(ErrorKind::InvalidArgument, "ssdf_lighting: draw {} lacks its mesh, SSDF asset or lobes", i);
    if (d.lobes->resolution != d.asset->resolution || d.lobes->count == 0 || d.lobes->count > ssdf::max_lobes)
      return fail(ErrorKind::InvalidArgument,
                  "ssdf_lighting: draw {} ('{}') has {} lobes for a {}x{} grid, its SSDF a {}x{} grid", i, d.mesh->name,
                  d.lobes->count, d.lobes->resolution, d.lobes->resolution, d.asset->resolution, d.asset->resolution);
    if (std::uint64_t(d.base_vertex) + d.mesh->vertex_count > d.asset->vertex_count)
      return fail(ErrorKind::InvalidArgument,
                  "ssdf_lighting: draw {} ('{}') reads SSDF rows {} .. {}, but the asset has {} vertices", i,
                  d.mesh->name, d.base_vertex, std::uint64_t(d.base_vertex) + d.mesh->vertex_count, d.asset->vertex_count);
  }
  // The direction table, each draw's lobes and each SSDF asset are persistent buffers.
  frame::ScenePassDesc desc{.name = "ssdf_lighting"};
  auto buffer = [&](const gpu::Buffer& b) { desc.buffers.push_back({b.label(), &b}); };
  buffer(state_->table);
  for (const SsdfDraw& d : draws) {
    buffer(d.lobes->buffer);
    buffer(d.asset->vertex_table);
    buffer(d.asset->cluster_table);
    buffer(d.asset->data);
  }
  auto state = state_;
  return frame::add_scene_color_pass(graph, std::move(desc), [state, draws](frame::ScenePassDraw& scene) {
    PassContext& ctx = scene.context;
    // One bind group per (asset, lobes) pair.
    std::vector<std::pair<std::pair<const SsdfGpuAsset*, const SsdfGpuLobes*>, const gpu::BindGroup*>> groups;
    auto group_for = [&](const SsdfDraw& draw) -> const gpu::BindGroup* {
      const auto key = std::pair{draw.asset, draw.lobes};
      for (auto& [k, g] : groups)
        if (k == key) return g;
      auto group = ctx.device().create_bind_group(
          {.label = "ssdf_lighting",
           .layout = &state->bind_layout,
           .entries = {gpu::bind(0, scene.uniforms), gpu::bind(1, scene.shadow_map, &state->shadow),
                       gpu::bind(2, state->table), gpu::bind(3, draw.lobes->buffer),
                       gpu::bind(4, draw.asset->vertex_table), gpu::bind(5, draw.asset->cluster_table),
                       gpu::bind(6, draw.asset->data)}});
      if (!group) {
        ctx.encoder().report_error(group.error());
        return nullptr;
      }
      groups.emplace_back(key, &ctx.keep(std::move(*group)));
      return groups.back().second;
    };
    auto pipeline = state->pipeline.at(ctx.device(), scene.samples);
    if (!pipeline) return ctx.encoder().report_error(pipeline.error());
    gpu::RenderPassEncoder& pass = scene.pass;
    pass.set_pipeline(**pipeline);
    for (const SsdfDraw& draw : draws) {
      const gpu::BindGroup* group = group_for(draw);
      if (!group) break;
      pass.set_bind_group(0, *group);
      const float half_spacing = 0.5f * std::sqrt(4.0f * pi) / float(draw.asset->resolution);  // DirectionGrid::spacing
      pass.push(SsdfPush{draw.model, vec4(draw.albedo, draw.shading == ssdf::ShadingMode::Pixel ? 1.0f : 0.0f),
                         glm::uvec4(draw.base_vertex, draw.lobes->count, draw.asset->directions, 0u),
                         vec4(half_spacing, 0.0f, 0.0f, 0.0f)});
      pass.set_vertex_buffer(0, draw.mesh->vertices);
      pass.set_index_buffer(draw.mesh->indices);
      pass.draw_indexed(draw.mesh->index_count);
    }
  });
}

}  // namespace weft::passes
