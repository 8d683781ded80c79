module;
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <memory>
#include <numeric>
#include <tuple>
#include <span>
#include <utility>
#include <vector>
#include "weft_pass_forward_shaders.h"
#include <weft/try.h>
module weft.base_pass.forward;

namespace weft::passes {

struct ForwardPass::State {
  gpu::BindGroupLayout bind_layout;
  gpu::BindGroupLayout material_layout;
  gpu::Texture white;        // the base colour, metallic-roughness, occlusion and emissive map of materials without one
  gpu::Texture flat_normal;  // (0.5, 0.5, 1): the normal map of materials without one (never sampled: maps.w = 0)
  std::shared_ptr<const gpu::PipelineLayout> layout;
  frame::PipelineSamples pipeline;
  gpu::Sampler shadow_sampler;
  gpu::Sampler environment_sampler;
  gpu::Sampler material_sampler;
};

namespace {
struct DrawConstants {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
  vec4 maps;  // normal scale, occlusion strength, uv1 bits, has a normal map
};
static_assert(sizeof(DrawConstants) == 112);  // forward.vert's DrawData, std430

Result<gpu::Texture> one_texel(gpu::Device& device, const char* label, std::array<std::uint8_t, 4> texel) {
  auto t = device.create_texture({.label = label, .size = {1, 1, 1}, .format = gpu::Format::RGBA8Unorm,
                                  .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!t) return t;
  WEFT_TRY_VOID(device.queue().write_texture(*t, std::as_bytes(std::span(texel))));
  return t;
}
}  // namespace

Result<ForwardPass> ForwardPass::create(gpu::Device& device) {
  WEFT_TRY(auto vs, device.create_shader_module({.label = "forward.vert", .stage = gpu::ShaderStage::Vertex, .spirv = shaders::forward_vert()}));
  WEFT_TRY(auto fs, device.create_shader_module({.label = "forward.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::forward_frag()}));
  WEFT_TRY(auto bind_layout, device.create_bind_group_layout(
        {.label = "forward",
         .entries = {{0, gpu::BindingType::UniformBuffer, gpu::ShaderStage::Vertex | gpu::ShaderStage::Fragment},
                     {1, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {2, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {3, gpu::BindingType::ReadOnlyStorageBuffer, gpu::ShaderStage::Vertex}}}));
  WEFT_TRY(auto material_layout, device.create_bind_group_layout(
        {.label = "forward-material",
         .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {1, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {2, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {3, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment},
                     {4, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}}));
  WEFT_TRY(auto white, one_texel(device, "white", {255, 255, 255, 255}));
  WEFT_TRY(auto flat_normal, one_texel(device, "flat-normal", {128, 128, 255, 255}));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout({.label = "forward",
                                                 .bind_group_layouts = {&bind_layout, &material_layout}}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  // weft's vertex layout plus the second UV set at location 5, which only this pass reads (an
  // attribute a shader does not consume is a validation warning, so the others go without).
  gpu::VertexBufferLayout vertices = frame::vertex_layout();
  vertices.attributes.push_back({gpu::VertexFormat::Float32x2, offsetof(frame::Vertex, uv1), 5});
  WEFT_TRY(auto pipeline, frame::create_lit_mesh_pipelines(device, "forward", layout, std::move(vs), std::move(fs),
                                                           std::move(vertices)));
  WEFT_TRY(auto shadow_sampler, frame::create_shadow_compare_sampler(device, "shadow-compare"));
  WEFT_TRY(auto environment_sampler, device.create_sampler({.label = "environment", .address_mode = gpu::AddressMode::Repeat}));
  WEFT_TRY(auto material_sampler, device.create_sampler({.label = "material", .address_mode = gpu::AddressMode::Repeat,
                                                          .max_anisotropy = 16.0f}));
  ForwardPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(bind_layout), std::move(material_layout), std::move(white),
                                              std::move(flat_normal), layout, std::move(pipeline),
                                              std::move(shadow_sampler), std::move(environment_sampler),
                                              std::move(material_sampler)});
  return pass;
}

Result<void> ForwardPass::add(RenderGraph& graph, std::span<const frame::DrawItem> items, vec4 clear_color,
                              std::uint32_t samples) const {
  auto state = state_;
  return frame::add_scene_color_pass(
      graph, {.name = "forward", .reads_environment = true, .clear_color = clear_color, .samples = samples},
      [state, items](frame::ScenePassDraw& draw) {
        PassContext& ctx = draw.context;
        // One material bind group per distinct set of maps and samplers (textures are
        // imported read-only assets, already in ShaderRead state).
        using MapKey = std::array<std::pair<const gpu::TextureView*, const gpu::Sampler*>, 5>;
        std::vector<std::pair<MapKey, const gpu::BindGroup*>> material_groups;
        auto material_group = [&](const frame::DrawItem& item) -> const gpu::BindGroup* {
          MapKey key;
          for (std::size_t i = 0; i < key.size(); ++i) {
            const gpu::TextureView* view = i == 0 ? item.base_color_texture : item.maps[i].view;
            if (!view) view = i == 2 ? &state->flat_normal.view() : &state->white.view();
            key[i] = {view, item.maps[i].sampler ? item.maps[i].sampler : &state->material_sampler};
          }
          for (auto& [k, g] : material_groups)
            if (k == key) return g;
          std::vector<gpu::BindGroupEntry> entries;
          for (std::uint32_t i = 0; i < key.size(); ++i) entries.push_back(gpu::bind(i, *key[i].first, key[i].second));
          auto g = ctx.device().create_bind_group(
              {.label = "forward-material", .layout = &state->material_layout, .entries = std::move(entries)});
          if (!g) {
            ctx.encoder().report_error(g.error());
            return nullptr;
          }
          material_groups.emplace_back(key, &ctx.keep(std::move(*g)));
          return material_groups.back().second;
        };
        // Objects that share a mesh and a material's maps are one instanced draw (30,000
        // copies of one mesh in one material: one draw); each instance's model matrix and
        // material factors are a record in a buffer made for this frame, in draw order.
        std::vector<const gpu::BindGroup*> group_of(items.size());
        for (std::size_t i = 0; i < items.size(); ++i)
          if (!(group_of[i] = material_group(items[i]))) return;
        std::vector<std::uint32_t> order(items.size());
        std::iota(order.begin(), order.end(), 0u);
        std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
          const auto key = [&](std::uint32_t i) {
            return std::tuple(reinterpret_cast<std::uintptr_t>(group_of[i]), reinterpret_cast<std::uintptr_t>(items[i].mesh), i);
          };
          return key(a) < key(b);
        });
        auto records = ctx.device().create_buffer({.label = "forward-draws",
                                                   .size = std::max<std::size_t>(items.size(), 1) * sizeof(DrawConstants),
                                                   .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::MapWrite});
        if (!records) return ctx.encoder().report_error(records.error());
        auto bytes = records->mapped();
        if (!bytes) return ctx.encoder().report_error(bytes.error());
        auto* record = reinterpret_cast<DrawConstants*>(bytes->data());
        for (std::size_t k = 0; k < order.size(); ++k) {
          const frame::DrawItem& item = items[order[k]];
          const auto& m = item.material;
          std::uint32_t uv1_bits = 0;
          for (std::uint32_t i = 0; i < item.maps.size(); ++i) uv1_bits |= (item.maps[i].texcoord == 1 ? 1u : 0u) << i;
          record[k] = DrawConstants{item.model, vec4(m.base_color, m.metallic), vec4(m.roughness, m.emissive),
                                    vec4(m.normal_scale, m.occlusion_strength, float(uv1_bits),
                                         item.maps[2].view ? 1.0f : 0.0f)};
        }
        const gpu::Buffer& draws = ctx.keep(std::move(*records));
        auto group = ctx.device().create_bind_group(
            {.label = "forward",
             .layout = &state->bind_layout,
             .entries = {gpu::bind(0, draw.uniforms), gpu::bind(1, draw.shadow_map, &state->shadow_sampler),
                         gpu::bind(2, *draw.environment, &state->environment_sampler), gpu::bind(3, draws)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));  // alive until the frame is done
        auto pipeline = state->pipeline.at(ctx.device(), draw.samples);
        if (!pipeline) return ctx.encoder().report_error(pipeline.error());
        gpu::RenderPassEncoder& pass = draw.pass;
        pass.set_pipeline(**pipeline);
        pass.set_bind_group(0, frame_group);
        for (std::size_t first = 0; first < order.size();) {
          const std::uint32_t i = order[first];
          std::size_t end = first + 1;
          while (end < order.size() && group_of[order[end]] == group_of[i] && items[order[end]].mesh == items[i].mesh) ++end;
          pass.set_bind_group(1, *group_of[i]);
          pass.set_vertex_buffer(0, items[i].mesh->vertices);
          pass.set_index_buffer(items[i].mesh->indices);
          pass.draw_indexed(items[i].mesh->index_count, std::uint32_t(end - first), 0, 0, std::uint32_t(first));
          first = end;
        }
      });
}

}  // namespace weft::passes
