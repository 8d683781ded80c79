// ShellFurPass: uploads (photo, band table, fins) and the render pass that draws fur objects.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include "weft_pass_shell_fur_shaders.h"
#include <weft/try.h>
module weft.pass.shell_fur;

namespace weft::passes {

using namespace fur;

namespace {


// The push constants of fur_common.glsl (128 bytes, the guaranteed minimum).
struct FurPush {
  mat4 model;
  vec4 tint_thickness;
  vec4 uv_layers;
  vec4 hair;
  vec4 specular;
};
static_assert(sizeof(FurPush) == 128);

FurPush push_constants(const ShellFurDraw& d) {
  const FurShading& s = d.shading;
  const float lift = s.lift_degrees * pi / 180.0f;
  return FurPush{d.model,
                 vec4(s.tint, s.thickness),
                 vec4(s.uv_scale, float(d.layers->table.layers), s.lighting == FurLighting::Lambert ? 0.0f : 1.0f),
                 vec4(s.comb ? *s.comb : vec2(0.0f), std::sin(lift), std::cos(lift)),
                 vec4(s.specular, s.shininess, s.fin_threshold, 0.0f)};
}

Result<gpu::Texture> upload_texture(gpu::Device& device, std::string label, std::uint32_t w, std::uint32_t h,
                                    gpu::Format format, std::span<const std::uint8_t> texels) {
  WEFT_TRY(auto texture, device.create_texture({.label = std::move(label), .size = {w, h, 1}, .format = format,
                                          .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst |
                                                   gpu::TextureUsage::CopySrc}));  // CopySrc: `weft render --output` reads it
  WEFT_TRY_VOID(device.queue().write_texture(texture, std::as_bytes(texels)));
  return std::move(texture);
}

std::uint64_t texture_bytes(const gpu::Texture& t) {
  return std::uint64_t(t.size().width) * t.size().height * gpu::format_info(t.format()).bytes_per_texel;
}

}  // namespace

std::uint64_t FurPhotoTexture::bytes() const { return texture_bytes(photo) + texture_bytes(orientation); }

std::uint64_t FurLayerTable::bytes() const {
  std::uint64_t total = bands.size();
  for (const auto& t : textures) total += texture_bytes(t);
  return total;
}

Result<FurPhotoTexture> upload_fur_photo(gpu::Device& device, const FurPhoto& photo, std::string_view label) {
  if (photo.width == 0 || photo.height == 0 || photo.rgba.size() != photo.texel_count() * 4 ||
      photo.orientation.size() != photo.texel_count() * 2)
    return fail(ErrorKind::InvalidArgument, "fur photo '{}': not an analysed photo (use analyze_fur_photo)", label);
  WEFT_TRY(auto rgba, upload_texture(device, weft::format("{}.photo", label), photo.width, photo.height, gpu::Format::RGBA8Srgb,
                               photo.rgba));
  WEFT_TRY(auto orientation, upload_texture(device, weft::format("{}.orientation", label), photo.width, photo.height,
                                      gpu::Format::RG8Unorm, photo.orientation));
  return FurPhotoTexture{std::move(rgba), std::move(orientation)};
}

Result<FurLayerTable> upload_band_table(gpu::Device& device, FurBandTable table, std::string_view label,
                                        const FurPhoto* photo_for_textures) {
  if (table.gpu.size() != std::size_t(table.layers) + 1 || table.layers == 0)
    return fail(ErrorKind::InvalidArgument, "fur band table '{}': not made by make_band_table", label);
  WEFT_TRY(auto bands, device.create_buffer_with_data(
        {.label = weft::format("{}.bands", label), .usage = gpu::BufferUsage::Storage}, std::as_bytes(std::span(table.gpu))));
  std::vector<gpu::Texture> textures;
  if (photo_for_textures) {
    const auto layers = make_shell_textures(*photo_for_textures, table);
    for (std::size_t n = 0; n < layers.size(); ++n) {
      WEFT_TRY(auto t, upload_texture(device, weft::format("{}.layer{}", label, n), photo_for_textures->width,
                                photo_for_textures->height, gpu::Format::RGBA8Srgb, layers[n]));
      textures.push_back(std::move(t));
    }
  }
  return FurLayerTable{std::move(table), std::move(bands), std::move(textures)};
}

Result<FurFins> upload_fins(gpu::Device& device, std::span<const FurFinEdge> edges, std::string_view label) {
  if (edges.empty()) return fail(ErrorKind::InvalidArgument, "fur fins '{}': the mesh has no edges", label);
  WEFT_TRY(auto buffer, device.create_buffer_with_data({.label = weft::format("{}.fins", label), .usage = gpu::BufferUsage::Storage},
                                                 std::as_bytes(edges)));
  return FurFins{std::move(buffer), std::uint32_t(edges.size())};
}

struct ShellFurPass::State {
  gpu::BindGroupLayout bind_layout;
  std::shared_ptr<const gpu::PipelineLayout> layout;
  // Shells, fins and the naive shells turn alpha into coverage under MSAA (fur_fragment.glsl).
  frame::PipelineSamples shells, fins, naive, skin_depth;
  gpu::Sampler mirror, repeat, shadow;
  // The same three testing the hair per sample under MSAA (ShellFurDraw::per_sample_hair),
  // where the adapter shades per sample.
  struct PerSample {
    frame::PipelineSamples shells, fins, naive;
  };
  std::optional<PerSample> per_sample;
};

Result<ShellFurPass> ShellFurPass::create(gpu::Device& device) {
  auto module = [&](std::string_view label, gpu::ShaderStage stage, std::span<const std::uint32_t> spirv) {
    return device.create_shader_module({.label = std::string(label), .stage = stage, .spirv = spirv});
  };
  auto shell_vs = module("shell_fur/shell.vert", gpu::ShaderStage::Vertex, shaders::shell_vert());
  auto fin_vs = module("shell_fur/fin.vert", gpu::ShaderStage::Vertex, shaders::fin_vert());
  auto shell_fs = module("shell_fur/shell.frag", gpu::ShaderStage::Fragment, shaders::shell_frag());
  auto fin_fs = module("shell_fur/fin.frag", gpu::ShaderStage::Fragment, shaders::fin_frag());
  auto naive_fs = module("shell_fur/shell_naive.frag", gpu::ShaderStage::Fragment, shaders::shell_naive_frag());
  auto skin_fs = module("shell_fur/skin_depth.frag", gpu::ShaderStage::Fragment, shaders::skin_depth_frag());
  for (auto* m : {&shell_vs, &fin_vs, &shell_fs, &fin_fs, &naive_fs, &skin_fs})
    if (!*m) return std::unexpected(m->error());
  using gpu::BindingType;
  using gpu::ShaderStage;
  auto bind_layout = device.create_bind_group_layout(
      {.label = "shell_fur",
       .entries = {{0, BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                   {1, BindingType::TextureSampler, ShaderStage::Fragment},
                   {2, BindingType::TextureSampler, ShaderStage::Fragment},
                   {3, BindingType::ReadOnlyStorageBuffer, ShaderStage::Fragment},
                   {4, BindingType::TextureSampler, ShaderStage::Fragment},
                   {5, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex}}});  // fin edges
  if (!bind_layout) return std::unexpected(bind_layout.error());
  WEFT_TRY(auto made_layout, device.create_pipeline_layout(
        {.label = "shell_fur", .bind_group_layouts = {&*bind_layout}, .push_constant_size = sizeof(FurPush)}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  // Each kept pipeline set owns its shaders: the shells' vertex shader is made once per set.
  auto vertex = [&] { return module("shell_fur/shell.vert", gpu::ShaderStage::Vertex, shaders::shell_vert()); };
  WEFT_TRY(auto naive_vs, vertex());
  WEFT_TRY(auto skin_vs, vertex());
  WEFT_TRY(auto shells, frame::create_lit_mesh_pipelines(device, "shell_fur.shells", layout, std::move(*shell_vs),
                                                         std::move(*shell_fs), frame::vertex_layout(), true));
  // The fins read their edges from a storage buffer: no vertex buffers.
  WEFT_TRY(auto fins, frame::PipelineSamples::create(device, layout,
                          {.label = "shell_fur.fins",
                           .layout = layout.get(),
                           .cull_mode = gpu::CullMode::None,
                           .color_targets = {{frame::scene_color_format}},
                           .depth_stencil = gpu::DepthStencilState{.format = frame::scene_depth_format}},
                          std::move(*fin_vs), std::move(*fin_fs), true));
  WEFT_TRY(auto naive, frame::create_lit_mesh_pipelines(device, "shell_fur.naive", layout, std::move(naive_vs),
                                                        std::move(*naive_fs), frame::vertex_layout(), true));
  // Under MSAA a draw may test each sample's own texel (supersampling the hair) where the
  // adapter can shade per sample: pipelines of their own, whose multisampled variants run
  // the *_per_sample.frag shaders (their 1-sample ones are the plain shaders).
  std::optional<State::PerSample> per_sample;
  if (device.adapter_info().features.sample_rate_shading) {
    auto frag = [&](const char* label, std::span<const std::uint32_t> spirv) {
      return module(label, gpu::ShaderStage::Fragment, spirv);
    };
    auto sv = vertex(), nv = vertex();
    auto fv = module("shell_fur/fin.vert", gpu::ShaderStage::Vertex, shaders::fin_vert());
    auto s1 = frag("shell_fur/shell.frag", shaders::shell_frag()), f1 = frag("shell_fur/fin.frag", shaders::fin_frag()),
         n1 = frag("shell_fur/shell_naive.frag", shaders::shell_naive_frag());
    auto sn = frag("shell_fur/shell_per_sample.frag", shaders::shell_per_sample_frag()),
         fn = frag("shell_fur/fin_per_sample.frag", shaders::fin_per_sample_frag()),
         nn = frag("shell_fur/shell_naive_per_sample.frag", shaders::shell_naive_per_sample_frag());
    for (auto* m : {&sv, &nv, &fv, &s1, &f1, &n1, &sn, &fn, &nn})
      if (!*m) return std::unexpected(m->error());
    WEFT_TRY(auto ps_shells, frame::create_lit_mesh_pipelines(device, "shell_fur.shells.per_sample", layout, std::move(*sv),
                                                              std::move(*s1), frame::vertex_layout(), true));
    WEFT_TRY(auto ps_fins, frame::PipelineSamples::create(device, layout,
                                                          {.label = "shell_fur.fins.per_sample",
                                                           .layout = layout.get(),
                                                           .cull_mode = gpu::CullMode::None,
                                                           .color_targets = {{frame::scene_color_format}},
                                                           .depth_stencil = gpu::DepthStencilState{.format = frame::scene_depth_format}},
                                                          std::move(*fv), std::move(*f1), true));
    WEFT_TRY(auto ps_naive, frame::create_lit_mesh_pipelines(device, "shell_fur.naive.per_sample", layout, std::move(*nv),
                                                             std::move(*n1), frame::vertex_layout(), true));
    ps_shells.set_multisample_fragment(std::move(*sn));
    ps_fins.set_multisample_fragment(std::move(*fn));
    ps_naive.set_multisample_fragment(std::move(*nn));
    per_sample.emplace(State::PerSample{std::move(ps_shells), std::move(ps_fins), std::move(ps_naive)});
  }
  // The skin's depth pre-pass: the skin (instance N of shell.vert) pushed back by a few depth
  // steps, colour untouched (adding zero). Any bias keeps the image: it only lets through
  // fragments that the skin, drawn again at its exact depth, hides anyway.
  WEFT_TRY(auto skin_depth, frame::PipelineSamples::create(device, layout,
        {.label = "shell_fur.skin_depth",
         .layout = layout.get(),
         .vertex_buffers = {frame::vertex_layout()},
         .cull_mode = gpu::CullMode::None,
         .color_targets = {{frame::scene_color_format, gpu::BlendMode::Additive}},
         .depth_stencil = gpu::DepthStencilState{.format = frame::scene_depth_format, .depth_bias_constant = 4.0f, .depth_bias_slope = 1.0f}},
        std::move(skin_vs), std::move(*skin_fs)));
  auto mirror = device.create_sampler({.label = "fur.mirror", .mipmap_filter = gpu::FilterMode::Nearest,
                                       .address_mode = gpu::AddressMode::MirrorRepeat, .max_lod = 0.0f});
  auto repeat = device.create_sampler({.label = "fur.repeat", .mipmap_filter = gpu::FilterMode::Nearest,
                                       .address_mode = gpu::AddressMode::Repeat, .max_lod = 0.0f});
  auto shadow = frame::create_shadow_compare_sampler(device, "fur.shadow");
  for (auto* s : {&mirror, &repeat, &shadow})
    if (!*s) return std::unexpected(s->error());
  ShellFurPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(*bind_layout), layout, std::move(shells),
                                              std::move(fins), std::move(naive), std::move(skin_depth), std::move(*mirror),
                                              std::move(*repeat), std::move(*shadow), std::move(per_sample)});
  return pass;
}

Result<void> ShellFurPass::add(RenderGraph& graph, std::span<const ShellFurDraw> draws) const {
  if (draws.empty()) return {};
  for (std::size_t i = 0; i < draws.size(); ++i) {
    const ShellFurDraw& d = draws[i];
    if (!d.mesh || !d.photo || !d.layers)
      return fail(ErrorKind::InvalidArgument, "shell_fur: draw {} lacks its mesh, photo or band table", i);
    if (!(d.shading.thickness >= 0.0f) || !std::isfinite(d.shading.thickness))
      return fail(ErrorKind::InvalidArgument, "shell_fur: draw {} ('{}') has thickness {}; it must be finite and >= 0", i,
                  d.mesh->name, d.shading.thickness);
    if (d.method == FurMethod::PerLayerTextures && d.layers->textures.size() != std::size_t(d.layers->table.layers) + 1)
      return fail(ErrorKind::InvalidArgument,
                  "shell_fur: draw {} ('{}') asks for the per-layer texture method, but its band table was uploaded "
                  "without textures (pass the photo to upload_band_table)",
                  i, d.mesh->name);
  }
  // Photos, orientation maps, band tables (and per-layer textures) are persistent assets.
  frame::ScenePassDesc desc{.name = "shell_fur"};
  for (const ShellFurDraw& d : draws) {
    desc.textures.push_back({d.photo->photo.label(), &d.photo->photo});
    desc.textures.push_back({d.photo->orientation.label(), &d.photo->orientation});
    if (d.method == FurMethod::PerLayerTextures)
      for (const auto& t : d.layers->textures) desc.textures.push_back({t.label(), &t});
    desc.buffers.push_back({d.layers->bands.label(), &d.layers->bands});
    if (d.fins) desc.buffers.push_back({d.fins->edges.label(), &d.fins->edges});
  }
  auto state = state_;
  return frame::add_scene_color_pass(graph, std::move(desc), [state, draws](frame::ScenePassDraw& scene) {
    PassContext& ctx = scene.context;
    auto group_for = [&](const ShellFurDraw& draw, const gpu::Texture& photo) -> const gpu::BindGroup* {
      const gpu::Sampler& sampler = draw.shading.wrap == FurWrap::Repeat ? state->repeat : state->mirror;
      auto group = ctx.device().create_bind_group(
          {.label = "shell_fur",
           .layout = &state->bind_layout,
           .entries = {gpu::bind(0, scene.uniforms), gpu::bind(1, photo.view(), &sampler),
                       gpu::bind(2, draw.photo->orientation.view(), &sampler), gpu::bind(3, draw.layers->bands),
                       gpu::bind(4, scene.shadow_map, &state->shadow),
                       // the fins' edges; any storage buffer where the draw has none (only fin.vert reads it)
                       gpu::bind(5, draw.fins ? draw.fins->edges : draw.layers->bands)}});
      if (!group) {
        ctx.encoder().report_error(group.error());
        return nullptr;
      }
      return &ctx.keep(std::move(*group));
    };
    auto pick = [&](const frame::PipelineSamples& set) -> const gpu::RenderPipeline* {
      auto p = set.at(ctx.device(), scene.samples);
      if (!p) {
        ctx.encoder().report_error(p.error());
        return nullptr;
      }
      return *p;
    };
    const gpu::RenderPipeline* skin_depth = pick(state->skin_depth);
    if (!skin_depth) return;
    gpu::RenderPassEncoder& pass = scene.pass;
    for (const ShellFurDraw& draw : draws) {
      const bool per_sample = draw.per_sample_hair && scene.samples > 1 && state->per_sample;
      const gpu::RenderPipeline* shells = pick(per_sample ? state->per_sample->shells : state->shells);
      const gpu::RenderPipeline* fins = pick(per_sample ? state->per_sample->fins : state->fins);
      const gpu::RenderPipeline* naive = pick(per_sample ? state->per_sample->naive : state->naive);
      if (!shells || !fins || !naive) return;
      const std::uint32_t layers = draw.layers->table.layers;
      FurPush push = push_constants(draw);
      push.specular.w = scene.samples > 1 ? 1.0f : 0.0f;  // alpha to coverage (fur_fragment.glsl)
      const gpu::BindGroup* group = group_for(draw, draw.photo->photo);  // over the photo: shells and fins
      if (!group) break;
      if (draw.method == FurMethod::SinglePhoto) {
        // The skin's depth first, pushed back a little: shell fragments behind the near side's
        // skin (the far side's shells, about half of all) then fail the depth test before their
        // shader runs. The skin's band keeps every texel, so it hides them anyway once the
        // shells draw it again at its exact depth: no pixel changes (docs/fur.md, Speed).
        pass.set_pipeline(*skin_depth);
        pass.set_bind_group(0, *group);
        pass.push(push);
        pass.set_vertex_buffer(0, draw.mesh->vertices);
        pass.set_index_buffer(draw.mesh->indices);
        pass.draw_indexed(draw.mesh->index_count, 1, 0, 0, layers);  // instance N: the skin
        // Tips first: with h_b = 0 the tips win the depth ties (the photo on the skin).
        pass.set_pipeline(*shells);
        pass.set_bind_group(0, *group);
        pass.push(push);
        pass.set_vertex_buffer(0, draw.mesh->vertices);
        pass.set_index_buffer(draw.mesh->indices);
        pass.draw_indexed(draw.mesh->index_count, layers + 1);
      } else {
        pass.set_pipeline(*naive);
        pass.push(push);
        pass.set_vertex_buffer(0, draw.mesh->vertices);
        pass.set_index_buffer(draw.mesh->indices);
        for (std::uint32_t n = 0; n <= layers; ++n) {
          const gpu::BindGroup* layer_group = group_for(draw, draw.layers->textures[n]);
          if (!layer_group) break;
          pass.set_bind_group(0, *layer_group);
          pass.draw_indexed(draw.mesh->index_count, 1, 0, 0, n);
        }
      }
      if (draw.fins && draw.fins->count > 0 && draw.shading.thickness > 0.0f) {
        pass.set_pipeline(*fins);
        pass.set_bind_group(0, *group);
        pass.push(push);
        pass.draw(6 * draw.fins->count);
      }
    }
  });
}

}  // namespace weft::passes
