// SkinSSSPass (the graph pass: pipeline, bind groups, draws) and the skin FeaturePass (the
// materials' parameters, their LUTs through the content-hash cache, textures, draw lists).
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
#include "weft_pass_skin_sss_shaders.h"
module weft.pass.skin_sss;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.feature;

namespace weft::passes {

namespace {
constexpr gpu::Format color_format = gpu::Format::RGBA16Float;  // weft.pass.forward's scene_color
constexpr gpu::Format depth_format = gpu::Format::Depth32Float;

// Matches `Draw` in skin_common.glsl.
struct SkinConstants {
  mat4 model;
  vec4 albedo_specular;
  vec4 params;
  vec4 normal_blur;
  vec4 transmit;
};
static_assert(sizeof(SkinConstants) == 128);

enum : int { flag_albedo_map = 1, flag_normal_map = 2, flag_screen_curvature = 4, flag_reference = 8 };
}  // namespace

struct SkinGpuMaterial {
  skin::SkinMaterial params;
  gpu::BindGroup group;
  int flags = 0;
};

struct SkinSSSPass::State {
  gpu::BindGroupLayout frame_layout;
  gpu::BindGroupLayout material_layout;
  gpu::BindGroupLayout reference_layout;
  gpu::Buffer no_reference;  // bound when a draw uses the LUT
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
  gpu::Sampler shadow_compare;
  gpu::Sampler shadow_depth;
  gpu::Sampler environment;
  gpu::Sampler lut;
  gpu::Sampler texture;
};

Result<SkinSSSPass> SkinSSSPass::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  auto vs = device.create_shader_module({.label = "skin.vert", .stage = ShaderStage::Vertex, .spirv = shaders::skin_vert()});
  if (!vs) return std::unexpected(vs.error());
  auto fs = device.create_shader_module({.label = "skin.frag", .stage = ShaderStage::Fragment, .spirv = shaders::skin_frag()});
  if (!fs) return std::unexpected(fs.error());
  auto frame_layout = device.create_bind_group_layout(
      {.label = "skin-frame",
       .entries = {{0, BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                   {1, BindingType::TextureSampler, ShaderStage::Fragment},
                   {2, BindingType::TextureSampler, ShaderStage::Fragment},
                   {3, BindingType::TextureSampler, ShaderStage::Fragment}}});
  if (!frame_layout) return std::unexpected(frame_layout.error());
  auto material_layout = device.create_bind_group_layout(
      {.label = "skin-material",
       .entries = {{0, BindingType::TextureSampler, ShaderStage::Fragment},
                   {1, BindingType::TextureSampler, ShaderStage::Fragment},
                   {2, BindingType::TextureSampler, ShaderStage::Fragment}}});
  if (!material_layout) return std::unexpected(material_layout.error());
  auto reference_layout = device.create_bind_group_layout(
      {.label = "skin-reference", .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Vertex}}});
  if (!reference_layout) return std::unexpected(reference_layout.error());
  const vec4 zero(0.0f);
  auto no_reference = device.create_buffer_with_data(
      {.label = "skin-no-reference", .size = sizeof(zero), .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
      std::as_bytes(std::span(&zero, 1)));
  if (!no_reference) return std::unexpected(no_reference.error());
  auto layout = device.create_pipeline_layout({.label = "skin",
                                               .bind_group_layouts = {&*frame_layout, &*material_layout, &*reference_layout},
                                               .push_constant_size = sizeof(SkinConstants)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = frame::create_lit_mesh_pipeline(device, "skin", *layout, *vs, *fs, color_format, depth_format);
  if (!pipeline) return std::unexpected(pipeline.error());
  auto shadow_compare = frame::create_shadow_compare_sampler(device, "skin-shadow-compare");
  if (!shadow_compare) return std::unexpected(shadow_compare.error());
  auto shadow_depth = device.create_sampler({.label = "skin-shadow-depth", .mag_filter = gpu::FilterMode::Nearest,
                                             .min_filter = gpu::FilterMode::Nearest,
                                             .mipmap_filter = gpu::FilterMode::Nearest, .max_lod = 0.0f});
  if (!shadow_depth) return std::unexpected(shadow_depth.error());
  auto environment = device.create_sampler({.label = "skin-environment", .address_mode = gpu::AddressMode::Repeat});
  if (!environment) return std::unexpected(environment.error());
  auto lut = device.create_sampler({.label = "skin-lut", .mipmap_filter = gpu::FilterMode::Nearest, .max_lod = 0.0f});
  if (!lut) return std::unexpected(lut.error());
  auto texture = device.create_sampler({.label = "skin-texture", .address_mode = gpu::AddressMode::Repeat});
  if (!texture) return std::unexpected(texture.error());
  SkinSSSPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(*frame_layout), std::move(*material_layout),
                                              std::move(*reference_layout), std::move(*no_reference), std::move(*layout),
                                              std::move(*pipeline), std::move(*shadow_compare), std::move(*shadow_depth),
                                              std::move(*environment), std::move(*lut), std::move(*texture)});
  return pass;
}

Result<std::shared_ptr<SkinGpuMaterial>> SkinSSSPass::create_material(gpu::Device& device, const skin::SkinMaterial& material,
                                                                      const gpu::Texture& lut, const gpu::Texture& albedo,
                                                                      const gpu::Texture& normal) const {
  auto group = device.create_bind_group({.label = "skin-material",
                                         .layout = &state_->material_layout,
                                         .entries = {gpu::bind(0, lut.view(), &state_->lut),
                                                     gpu::bind(1, albedo.view(), &state_->texture),
                                                     gpu::bind(2, normal.view(), &state_->texture)}});
  if (!group) return std::unexpected(group.error());
  auto out = std::make_shared<SkinGpuMaterial>(SkinGpuMaterial{material, std::move(*group), 0});
  if (!material.albedo_texture.empty()) out->flags |= flag_albedo_map;
  if (!material.normal_texture.empty()) out->flags |= flag_normal_map;
  if (material.curvature == skin::CurvatureSource::Screen) out->flags |= flag_screen_curvature;
  return out;
}

Result<void> SkinSSSPass::add(RenderGraph& graph, std::span<const SkinDraw> draws,
                              std::span<const std::shared_ptr<SkinGpuMaterial>> materials,
                              std::span<const gpu::Texture* const> luts) const {
  struct Data {
    BufferHandle uniforms;
    TextureHandle shadow_map, environment, color, depth;
    std::vector<BufferHandle> references;  // per draw; invalid: the LUT
  };
  auto& board = graph.blackboard();
  auto uniforms = board.get<BufferHandle>("frame_uniforms");
  auto shadow_map = board.get<TextureHandle>("shadow_map");
  auto environment = board.get<TextureHandle>("environment");
  auto color = board.get<TextureHandle>("scene_color");
  auto depth = board.get<TextureHandle>("scene_depth");
  for (const Error* e : {uniforms ? nullptr : &uniforms.error(), shadow_map ? nullptr : &shadow_map.error(),
                         environment ? nullptr : &environment.error(), color ? nullptr : &color.error(),
                         depth ? nullptr : &depth.error()})
    if (e) return std::unexpected(*e);
  for (const auto& d : draws)
    if (!d.mesh || d.material >= materials.size() || !materials[d.material])
      return fail(ErrorKind::InvalidArgument, "skin pass: a draw names material {} of {} (or has no mesh)", d.material,
                  materials.size());
  std::vector<TextureHandle> lut_handles;
  for (std::size_t i = 0; i < luts.size(); ++i)
    lut_handles.push_back(graph.import_texture(luts.size() == 1 ? std::string("skin_lut") : weft::format("skin_lut_{}", i),
                                               luts[i], gpu::Access::ShaderRead));
  std::vector<BufferHandle> reference_handles;
  for (std::size_t i = 0; i < draws.size(); ++i)
    reference_handles.push_back(draws[i].reference ? graph.import_buffer(weft::format("skin_reference_{}", i),
                                                                          draws[i].reference, gpu::Access::StorageRead)
                                                   : BufferHandle{});
  auto state = state_;
  auto& data = graph.add_pass<Data>(
      "skin_sss",
      [&](PassBuilder& b, Data& d) {
        d.uniforms = b.read(*uniforms, BufferUse::Uniform);
        d.shadow_map = b.read(*shadow_map, TextureUse::Sampled);
        d.environment = b.read(*environment, TextureUse::Sampled);
        for (auto h : lut_handles) b.read(h, TextureUse::Sampled);
        for (auto h : reference_handles) d.references.push_back(h ? b.read(h, BufferUse::StorageRead) : h);
        d.color = b.write(*color, TextureUse::ColorAttachment);
        d.depth = b.write(*depth, TextureUse::DepthAttachment);
      },
      [state, draws, materials](const PassResources& res, const Data& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "skin-frame",
             .layout = &state->frame_layout,
             .entries = {gpu::bind(0, res.buffer(d.uniforms)), gpu::bind(1, res.view(d.shadow_map), &state->shadow_compare),
                         gpu::bind(2, res.view(d.shadow_map), &state->shadow_depth),
                         gpu::bind(3, res.view(d.environment), &state->environment)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));
        // The per-draw reference buffers (the reference mode), or a dummy for LUT draws.
        auto none = ctx.device().create_bind_group(
            {.label = "skin-no-reference", .layout = &state->reference_layout, .entries = {gpu::bind(0, state->no_reference)}});
        if (!none) return ctx.encoder().report_error(none.error());
        std::vector<const gpu::BindGroup*> reference_groups(draws.size(), &ctx.keep(std::move(*none)));
        for (std::size_t i = 0; i < draws.size(); ++i) {
          if (!d.references[i]) continue;
          auto reference = ctx.device().create_bind_group({.label = "skin-reference",
                                                           .layout = &state->reference_layout,
                                                           .entries = {gpu::bind(0, res.buffer(d.references[i]))}});
          if (!reference) return ctx.encoder().report_error(reference.error());
          reference_groups[i] = &ctx.keep(std::move(*reference));
        }
        auto pass = ctx.encoder().begin_render_pass(
            {.label = "skin_sss",
             .color_attachments = {{.view = &res.view(d.color), .load = gpu::LoadOp::Load}},
             .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth), .load = gpu::LoadOp::Load}});
        pass.set_pipeline(state->pipeline);
        pass.set_bind_group(0, frame_group);
        for (std::size_t i = 0; i < draws.size(); ++i) {
          const SkinDraw& draw = draws[i];
          const SkinGpuMaterial& mat = *materials[draw.material];
          const int flags = mat.flags | (d.references[i] ? flag_reference : 0);
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
                            float(flags + 16 * int(m.debug_view)), m.shadow_scatter_mm / m.mm_per_unit);
          pass.set_bind_group(1, mat.group);
          pass.push(c);
          pass.set_vertex_buffer(0, draw.mesh->vertices);
          pass.set_index_buffer(draw.mesh->indices);
          pass.draw_indexed(draw.mesh->index_count);
        }
        pass.end();
      });
  board.put("scene_color", data.color);
  board.put("scene_depth", data.depth);
  return {};
}

// ---- the feature ------------------------------------------------------------------------

namespace {

Result<gpu::Texture> upload_rgba8(gpu::Device& device, std::string_view label, std::uint32_t w, std::uint32_t h,
                                  gpu::Format format, std::span<const std::uint8_t> rgba) {
  auto t = device.create_texture({.label = std::string(label), .size = {w, h, 1}, .format = format,
                                  .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!t) return std::unexpected(t.error());
  if (auto ok = device.queue().write_texture(*t, std::as_bytes(rgba)); !ok) return std::unexpected(ok.error());
  return std::move(*t);
}

Result<gpu::Texture> upload_lut(gpu::Device& device, const skin::SkinLut& lut) {
  std::vector<std::uint16_t> half(lut.texels.size() * 4);
  for (std::size_t i = 0; i < lut.texels.size(); ++i)
    for (int c = 0; c < 4; ++c) half[i * 4 + c] = glm::packHalf1x16(lut.texels[i][c]);
  auto t = device.create_texture({.label = "skin_lut_" + hex64(lut.hash), .size = {lut.width, lut.height, 1},
                                  .format = gpu::Format::RGBA16Float,
                                  .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!t) return std::unexpected(t.error());
  if (auto ok = device.queue().write_texture(*t, std::as_bytes(std::span(half))); !ok) return std::unexpected(ok.error());
  return std::move(*t);
}

class SkinFeature final : public FeaturePass {
 public:
  SkinFeature(gpu::Device& device, SkinSSSPass pass, gpu::Texture white, gpu::Texture flat)
      : device_(&device), pass_(std::move(pass)), white_(std::move(white)), flat_normal_(std::move(flat)) {}

  [[nodiscard]] std::string_view name() const override { return "skin"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    warnings_.clear();
    draws_.clear();
    frame_materials_.clear();
    frame_luts_.clear();
    std::map<std::uint32_t, std::uint32_t> slot_of;  // scene material -> frame material slot
    std::vector<std::string> problems;
    for (std::uint32_t object_index : frame.objects) {
      const scene::Object& object = frame.scene.objects.at(object_index);
      auto slot = slot_of.find(object.material);
      if (slot == slot_of.end()) {
        auto material = material_for(frame.scene.materials.at(object.material), frame.quality);
        if (!material) {
          problems.push_back(material.error().message);
          slot_of[object.material] = ~0u;
          continue;
        }
        slot = slot_of.emplace(object.material, std::uint32_t(frame_materials_.size())).first;
        frame_materials_.push_back(*material);
        const gpu::Texture* lut = lut_textures_.at((*material)->params.lut.hash()).get();
        if (std::find(frame_luts_.begin(), frame_luts_.end(), lut) == frame_luts_.end()) frame_luts_.push_back(lut);
      }
      if (slot->second == ~0u) continue;
      const scene::Mesh& mesh = frame.scene.meshes.at(object.mesh);
      const auto& params = frame_materials_[slot->second]->params;
      if (!mesh.has_uvs() && (!params.albedo_texture.empty() || !params.normal_texture.empty()))
        warnings_.push_back(weft::format("skin object '{}': mesh '{}' has no UVs, so its textures sample one texel",
                                         object.name, mesh.name));
      draws_.push_back({frame.meshes[object.mesh], object.transform, slot->second});
    }
    if (!problems.empty()) {
      std::string message = problems.front();
      for (std::size_t i = 1; i < problems.size(); ++i) message += "\n" + problems[i];
      return std::unexpected(Error{ErrorKind::Parse, std::move(message)});
    }
    if (frame.uniforms.light_color != vec4(0.0f)) {
      for (std::size_t i = 0; i < draws_.size(); ++i) {
        if (!frame_materials_[draws_[i].material]->params.reference) continue;  // set by the preset or the material
        const scene::Object& object = frame.scene.objects.at(frame.objects[i]);
        auto reference = reference_for(frame.scene.meshes.at(object.mesh), object.transform,
                                       frame_materials_[draws_[i].material]->params, vec3(frame.uniforms.light_direction));
        if (!reference) return with_context(weft::format("skin reference for object '{}'", object.name), reference.error());
        draws_[i].reference = *reference;
      }
    }
    if (frame.uniforms.light_color == vec4(0.0f))
      warnings_.push_back("skin materials without a directional (key) light show only their ambient term");
    return {};
  }

  Result<void> add_passes(RenderGraph& graph, const FeatureFrame&) override {
    return pass_.add(graph, draws_, frame_materials_, frame_luts_);
  }

  [[nodiscard]] std::vector<std::string> warnings() const override { return warnings_; }

 private:
  Result<std::shared_ptr<SkinGpuMaterial>> material_for(const scene::Material& material, Quality quality) {
    Hasher h;
    h.str(material.name).str(material.params.dump()).str(material.base_dir.string()).str(material.json_path);
    h.value(std::uint8_t(quality));
    const std::uint64_t key = h.digest();
    if (auto it = materials_.find(key); it != materials_.end()) return it->second;
    auto parsed = skin::parse_skin_material(material, quality);
    if (!parsed) return std::unexpected(parsed.error());
    const std::uint64_t lut_key = parsed->lut.hash();
    if (!lut_textures_.contains(lut_key)) {
      auto lut = skin::cached_lut(parsed->lut);
      if (!lut) return with_context(weft::format("skin material '{}'", material.name), lut.error());
      auto texture = upload_lut(*device_, **lut);
      if (!texture) return std::unexpected(texture.error());
      lut_textures_.emplace(lut_key, std::make_unique<gpu::Texture>(std::move(*texture)));
    }
    auto albedo = texture_for(parsed->albedo_texture, gpu::Format::RGBA8Srgb);
    if (!albedo) return with_context(weft::format("skin material '{}' albedo_texture", material.name), albedo.error());
    auto normal = texture_for(parsed->normal_texture, gpu::Format::RGBA8Unorm);
    if (!normal) return with_context(weft::format("skin material '{}' normal_texture", material.name), normal.error());
    auto gpu_material = pass_.create_material(*device_, *parsed, *lut_textures_.at(lut_key), *albedo ? **albedo : white_,
                                              *normal ? **normal : flat_normal_);
    if (!gpu_material) return std::unexpected(gpu_material.error());
    materials_.emplace(key, *gpu_material);
    return *gpu_material;
  }

  // Brute-force diffuse per vertex for the key light (the reference mode), one vec4 per vertex,
  // computed once per mesh, light direction and scale.
  Result<const gpu::Buffer*> reference_for(const scene::Mesh& mesh, const mat4& model, const skin::SkinMaterial& m,
                                           vec3 towards_light) {
    const mat3 linear(model);
    const float scale = std::cbrt(std::abs(glm::determinant(linear)));
    if (!(scale > 0.0f) || !std::isfinite(scale)) return fail(ErrorKind::InvalidArgument, "the object's transform is singular");
    const vec3 light = glm::normalize(glm::inverse(linear) * towards_light);
    const double mm_per_unit = double(m.mm_per_unit) * scale;
    Hasher h;
    h.bytes(mesh.positions.data(), mesh.positions.size() * sizeof(vec3));
    h.bytes(mesh.normals.data(), mesh.normals.size() * sizeof(vec3));
    h.bytes(mesh.indices.data(), mesh.indices.size() * sizeof(std::uint32_t));
    h.value(light).value(mm_per_unit).value(m.lut.convention.normalization).value(m.lut.convention.variance_scale);
    const std::uint64_t key = h.digest();
    if (auto it = references_.find(key); it != references_.end()) return it->second.get();
    log::info(weft::format("skin reference: brute-force scattering on mesh '{}' ({} vertices)", mesh.name,
                           mesh.positions.size()));
    // The physical profile, as the references of docs/skin.md.
    auto diffuse = skin::mesh_reference(mesh, {.towards_light = light, .mm_per_unit = mm_per_unit});
    if (!diffuse) return std::unexpected(diffuse.error());
    std::vector<vec4> texels(diffuse->size());
    for (std::size_t i = 0; i < texels.size(); ++i) texels[i] = vec4((*diffuse)[i], 1.0f);
    auto buffer = device_->create_buffer_with_data(
        {.label = "skin_reference_" + mesh.name, .size = texels.size() * sizeof(vec4),
         .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
        std::as_bytes(std::span(texels)));
    if (!buffer) return std::unexpected(buffer.error());
    return references_.emplace(key, std::make_unique<gpu::Buffer>(std::move(*buffer))).first->second.get();
  }

  // The texture at `path` (nullptr when the path is empty), loaded once.
  Result<const gpu::Texture*> texture_for(const std::filesystem::path& path, gpu::Format format) {
    if (path.empty()) return nullptr;
    const std::string key = path.string() + (format == gpu::Format::RGBA8Srgb ? "#srgb" : "#linear");
    if (auto it = textures_.find(key); it != textures_.end()) return it->second.get();
    auto img = image::load_ldr(path);
    if (!img) return std::unexpected(img.error());
    std::vector<std::uint8_t> rgba(std::size_t(img->width) * img->height * 4, 255);
    for (std::size_t i = 0; i < std::size_t(img->width) * img->height; ++i) {
      const std::uint8_t* p = &img->pixels[i * img->channels];
      const bool gray = img->channels < 3;
      for (int c = 0; c < 3; ++c) rgba[i * 4 + c] = gray ? p[0] : p[c];
      if (img->channels == 4) rgba[i * 4 + 3] = p[3];
    }
    auto t = upload_rgba8(*device_, path.filename().string(), img->width, img->height, format, rgba);
    if (!t) return std::unexpected(t.error());
    return textures_.emplace(key, std::make_unique<gpu::Texture>(std::move(*t))).first->second.get();
  }

  gpu::Device* device_;
  SkinSSSPass pass_;
  gpu::Texture white_, flat_normal_;
  std::map<std::uint64_t, std::unique_ptr<gpu::Texture>> lut_textures_;  // by LUT content hash
  std::map<std::string, std::unique_ptr<gpu::Texture>> textures_;
  std::map<std::uint64_t, std::shared_ptr<SkinGpuMaterial>> materials_;  // by params + quality
  std::map<std::uint64_t, std::unique_ptr<gpu::Buffer>> references_;     // by mesh, light and scale
  // This frame's inputs, alive until the graph has executed.
  std::vector<SkinDraw> draws_;
  std::vector<std::shared_ptr<SkinGpuMaterial>> frame_materials_;
  std::vector<const gpu::Texture*> frame_luts_;
  std::vector<std::string> warnings_;
};

}  // namespace

Result<std::unique_ptr<FeaturePass>> create_skin_feature(gpu::Device& device) {
  auto pass = SkinSSSPass::create(device);
  if (!pass) return std::unexpected(pass.error());
  const std::uint8_t white_texel[4] = {255, 255, 255, 255};
  const std::uint8_t flat_texel[4] = {128, 128, 255, 255};
  auto white = upload_rgba8(device, "skin-white", 1, 1, gpu::Format::RGBA8Srgb, white_texel);
  if (!white) return std::unexpected(white.error());
  auto flat = upload_rgba8(device, "skin-flat-normal", 1, 1, gpu::Format::RGBA8Unorm, flat_texel);
  if (!flat) return std::unexpected(flat.error());
  return std::make_unique<SkinFeature>(device, std::move(*pass), std::move(*white), std::move(*flat));
}

}  // namespace weft::passes
