// The skin_sss feature: its descriptor (registration, knob table) and its FeaturePass (the
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
#include <weft/try.h>
module weft.pass.skin_sss;

namespace weft::passes {

// ---- the feature ------------------------------------------------------------------------

namespace {

Result<gpu::Texture> upload_rgba8(gpu::Device& device, std::string_view label, std::uint32_t w, std::uint32_t h,
                                  gpu::Format format, std::span<const std::uint8_t> rgba) {
  WEFT_TRY(auto t, device.create_texture({.label = std::string(label), .size = {w, h, 1}, .format = format,
                                    .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst |
                                                   gpu::TextureUsage::CopySrc}));  // CopySrc: `weft render --output` reads it
  WEFT_TRY_VOID(device.queue().write_texture(t, std::as_bytes(rgba)));
  return std::move(t);
}

gpu::TextureDescriptor lut_descriptor(const skin::LutParams& params) {
  return {.label = "skin_lut_" + hex64(params.hash()), .size = {params.width, params.height, 1},
          .format = gpu::Format::RGBA16Float,
          .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst |
                   gpu::TextureUsage::CopySrc};  // CopySrc: `weft render --output` reads it
}

Result<gpu::Texture> upload_lut(gpu::Device& device, const skin::SkinLut& lut) {
  std::vector<std::uint16_t> half(lut.texels.size() * 4);
  for (std::size_t i = 0; i < lut.texels.size(); ++i)
    for (int c = 0; c < 4; ++c) half[i * 4 + c] = glm::packHalf1x16(lut.texels[i][c]);
  WEFT_TRY(auto t, device.create_texture(lut_descriptor(lut.params)));
  WEFT_TRY_VOID(device.queue().write_texture(t, std::as_bytes(std::span(half))));
  return std::move(t);
}

class SkinFeature final : public FeaturePass {
 public:
  // The factory the descriptor names: the graph pass first, then the feature around it.
  static Result<std::unique_ptr<FeaturePass>> create(gpu::Device& device) {
    WEFT_TRY(auto pass, SkinSSSPass::create(device));
    const std::uint8_t white_texel[4] = {255, 255, 255, 255};
    const std::uint8_t flat_texel[4] = {128, 128, 255, 255};
    WEFT_TRY(auto white, upload_rgba8(device, "skin-white", 1, 1, gpu::Format::RGBA8Srgb, white_texel));
    WEFT_TRY(auto flat, upload_rgba8(device, "skin-flat-normal", 1, 1, gpu::Format::RGBA8Unorm, flat_texel));
    return std::make_unique<SkinFeature>(device, std::move(pass), std::move(white), std::move(flat));
  }

  SkinFeature(gpu::Device& device, SkinSSSPass pass, gpu::Texture white, gpu::Texture flat)
      : device_(&device), pass_(std::move(pass)), white_(std::move(white)), flat_normal_(std::move(flat)) {}

  [[nodiscard]] std::string_view name() const override { return "skin_sss"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    warnings_.clear();
    draws_.clear();
    frame_materials_.clear();
    frame_luts_.clear();
    WEFT_TRY_VOID(resolve_materials(
        frame, frame_materials_,
        [&](const scene::Material& material) { return material_for(material, frame.quality); },
        [&](std::uint32_t object_index, std::uint32_t slot) {
          const scene::Object& object = frame.scene.objects.at(object_index);
          const scene::Mesh& mesh = frame.scene.meshes.at(object.mesh);
          const auto& params = frame_materials_[slot]->params;
          if (!mesh.has_uvs() &&
              (!params.albedo_texture.empty() || !params.normal_texture.empty() || !params.specular_texture.empty()))
            warnings_.push_back(weft::format("skin object '{}': mesh '{}' has no UVs, so its textures sample one texel",
                                             object.name, mesh.name));
          draws_.push_back({frame.meshes[object.mesh], object.transform, slot});
        }));
    for (const auto& material : frame_materials_) {
      const gpu::Texture* lut = lut_textures_.at(material->params.lut.hash()).get();
      if (std::find(frame_luts_.begin(), frame_luts_.end(), lut) == frame_luts_.end()) frame_luts_.push_back(lut);
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
    WEFT_TRY(auto parsed, skin::parse_skin_material(material, quality));
    const std::uint64_t lut_key = parsed.lut.hash();
    if (!lut_textures_.contains(lut_key) && device_->declaring()) {
      // A declared frame (no adapter): the LUT's texture at its size, and no bake.
      WEFT_TRY(auto texture, device_->create_texture(lut_descriptor(parsed.lut)));
      lut_textures_.emplace(lut_key, std::make_unique<gpu::Texture>(std::move(texture)));
    }
    if (!lut_textures_.contains(lut_key)) {
      auto lut = skin::cached_lut(parsed.lut);
      if (!lut) return with_context(weft::format("skin material '{}'", material.name), lut.error());
      WEFT_TRY(auto texture, upload_lut(*device_, **lut));
      lut_textures_.emplace(lut_key, std::make_unique<gpu::Texture>(std::move(texture)));
    }
    auto albedo = texture_for(parsed.albedo_texture, gpu::Format::RGBA8Srgb);
    if (!albedo) return with_context(weft::format("skin material '{}' albedo_texture", material.name), albedo.error());
    auto normal = texture_for(parsed.normal_texture, gpu::Format::RGBA8Unorm, image::MipContent::NormalMap);
    if (!normal) return with_context(weft::format("skin material '{}' normal_texture", material.name), normal.error());
    auto specular = texture_for(parsed.specular_texture, gpu::Format::RGBA8Unorm);
    if (!specular) return with_context(weft::format("skin material '{}' specular_texture", material.name), specular.error());
    WEFT_TRY(auto gpu_material, pass_.create_material(*device_, parsed, *lut_textures_.at(lut_key), *albedo ? **albedo : white_,
                                                *normal ? **normal : flat_normal_, *specular ? **specular : white_));
    materials_.emplace(key, gpu_material);
    return gpu_material;
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
    if (device_->declaring()) {  // a declared frame: the buffer at its size, no brute-force gather
      WEFT_TRY(auto buffer, device_->create_buffer({.label = "skin_reference_" + mesh.name,
                                                    .size = std::max<std::size_t>(mesh.positions.size(), 1) * sizeof(vec4),
                                                    .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst}));
      return references_.emplace(key, std::make_unique<gpu::Buffer>(std::move(buffer))).first->second.get();
    }
    log::info(weft::format("skin reference: brute-force scattering on mesh '{}' ({} vertices)", mesh.name,
                           mesh.positions.size()));
    // The physical profile, as the references of docs/skin.md.
    WEFT_TRY(auto diffuse, skin::mesh_reference(mesh, {.towards_light = light, .mm_per_unit = mm_per_unit}));
    std::vector<vec4> texels(diffuse.size());
    for (std::size_t i = 0; i < texels.size(); ++i) texels[i] = vec4((diffuse)[i], 1.0f);
    WEFT_TRY(auto buffer, device_->create_buffer_with_data(
          {.label = "skin_reference_" + mesh.name, .size = texels.size() * sizeof(vec4),
           .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
          std::as_bytes(std::span(texels))));
    return references_.emplace(key, std::make_unique<gpu::Buffer>(std::move(buffer))).first->second.get();
  }

  // The texture at `path` (nullptr when the path is empty), loaded once.
  Result<const gpu::Texture*> texture_for(const std::filesystem::path& path, gpu::Format format,
                                          image::MipContent content = image::MipContent::Linear) {
    // A declared frame binds the placeholders: the maps are no resources of the graph.
    if (path.empty() || device_->declaring()) return nullptr;
    const std::string key = path.string() + (format == gpu::Format::RGBA8Srgb                  ? "#srgb"
                                             : content == image::MipContent::NormalMap ? "#normal"
                                                                                       : "#linear");
    if (auto it = textures_.find(key); it != textures_.end()) return it->second.get();
    WEFT_TRY(auto img, image::load_ldr(path));
    std::vector<std::uint8_t> rgba(std::size_t(img.width) * img.height * 4, 255);
    for (std::size_t i = 0; i < std::size_t(img.width) * img.height; ++i) {
      const std::uint8_t* p = &img.pixels[i * img.channels];
      const bool gray = img.channels < 3;
      for (int c = 0; c < 3; ++c) rgba[i * 4 + c] = gray ? p[0] : p[c];
      if (img.channels == 4) rgba[i * 4 + 3] = p[3];
    }
    // With its mip chain (sRGB in linear light, normals renormalised): the 4K scan's maps are
    // filtered when the head is small on screen, not point-sampled.
    const auto chain = image::rgba8_mip_chain(rgba, img.width, img.height,
                                              format == gpu::Format::RGBA8Srgb ? image::MipContent::Srgb : content);
    std::vector<std::span<const std::byte>> levels;
    for (const auto& level : chain) levels.push_back(std::as_bytes(std::span(level)));
    WEFT_TRY(auto t, device_->create_texture({.label = path.filename().string(), .size = {img.width, img.height, 1},
                                              .format = format,
                                              .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst |
                                                       gpu::TextureUsage::CopySrc,
                                              .mip_level_count = std::uint32_t(chain.size())}));
    WEFT_TRY_VOID(device_->queue().write_texture_levels(t, levels));
    return textures_.emplace(key, std::make_unique<gpu::Texture>(std::move(t))).first->second.get();
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

// Quality picks lut.size and lut.samples (64/128, 256/256, 512/512, 1024/1024) and, at
// reference, the brute-force mode (docs/skin.md, docs/tradeoffs.md).
const FeatureDescriptor& skin_sss_feature() {
  static const FeatureDescriptor feature{
      .name = "skin_sss", .aliases = {"skin"}, .doc = "docs/skin.md",
      .summary = "pre-integrated subsurface scattering for skin (curvature-adaptive LUT)",
      .check_material = check_by_parsing<&skin::parse_skin_material>, .create = &SkinFeature::create,
      .passes = {"skin_sss"},
      // The stability sweep stops at the reference preset's 1024: 4096 texels and 65,536
      // samples are a bake of hours.
      .knobs = {
          with_extremes(integer_knob("lut.size", 2, 4096, {8, 16, 32, 64, 128, 256, 512, 1024}, "LUT texels per side (N.L by 1/r)"),
                        std::nullopt, 1024),
          with_extremes(integer_knob("lut.samples", 2, 65536, {4, 8, 16, 32, 64, 128, 256, 1024}, "ring samples per Gaussian when baking"),
                        std::nullopt, 1024),
          choice_knob("lut.range", {"penner", "adaptive", "full"}, "integration range around the ring"),
          choice_knob("lut.quadrature", {"per-gaussian", "uniform"}, "one grid per Gaussian, or Penner's single grid"),
          choice_knob("curvature", {"vertex", "screen"}, "1/r from the mesh per vertex, or from screen derivatives"),
      },
      .preset_values = [](Quality q) -> nlohmann::json {
        const auto p = skin::skin_quality_preset(q);
        return {{"lut.size", p.lut_size}, {"lut.samples", p.lut_samples}, {"reference", p.reference}};
      },
      // The brute-force gather of d'Eon's profile over the mesh, per vertex, for the key light
      // (skin::mesh_reference): the scattering the LUT approximates, without the ring model.
      .reference = {{"reference", true}},
      .reference_why = "\"reference\": true: brute-force scattering gathered over the mesh per vertex",
      // Every LUT costs the same per frame (one texture, the same fetches): the knobs trade
      // bake time, so the cost is the cold first frame with the LUT's disk cache off.
      .cost = CostAxis::ColdFrame,
      .environment = {{"WEFT_SKIN_LUT_CACHE", ""}},
      .clear_caches = &skin::clear_lut_memory_cache,
      .bakes = {{.name = "skin-lut", .summary = "The pre-integrated skin LUT: RGB diffuse over (N·L, 1/r), alpha Beckmann", .add = &detail::add_skin_lut_bake}},
  };
  return feature;
}

}  // namespace weft::passes
