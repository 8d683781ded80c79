module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <map>
#include <filesystem>
#include <functional>
#include <set>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <weft/try.h>
module weft.renderer;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.pipeline;

namespace weft::renderer {

struct Renderer::State {
  gpu::Device* device = nullptr;
  CacheStats stats;
  // The pipeline's pass instances by pass name; an instance is kept while the pipeline names
  // a pass of that name with the same type and options.
  struct Instance {
    const pipeline::PassTypeDescriptor* type = nullptr;
    pipeline::PassOptions options;
    std::unique_ptr<pipeline::FramePass> pass;
  };
  std::map<std::string, Instance, std::less<>> instances;
  std::optional<pipeline::Pipeline> default_pipeline;
  // Pipeline files named by scenes, by path, with the modification time they were read at.
  struct LoadedPipeline {
    std::filesystem::file_time_type mtime;
    pipeline::Pipeline pipeline;
  };
  std::map<std::filesystem::path, LoadedPipeline> pipeline_files;
  std::unordered_map<std::uint64_t, frame::GpuMesh> meshes;
  // Material maps by source and colour space ("srgb:" / "linear:" + path, or a hash of
  // embedded bytes); empty = failed to load. Samplers by their glTF settings.
  std::unordered_map<std::string, std::optional<gpu::Texture>> textures;
  std::vector<std::pair<scene::TextureSampler, gpu::Sampler>> samplers;
  std::uint64_t environment_key = 0;
  std::optional<gpu::Texture> environment;
  std::array<vec4, 9> environment_sh{};
  std::optional<gpu::Buffer> uniforms;
  std::optional<gpu::Texture> output;
  // Host-visible copies of the resources a frame reads back (RenderOptions::read_hdr and
  // ::outputs), by resource name.
  std::map<std::string, gpu::Buffer, std::less<>> readback_buffers;
  struct PendingReadback {
    std::string name;        // what the caller asked for ("pass.slot" or a resource name)
    gpu::Format format = gpu::Format::Undefined;
    std::uint32_t width = 0, height = 0;
    const gpu::Buffer* buffer = nullptr;
    bool hdr = false;        // RenderOptions::read_hdr's image
  };
  std::vector<PendingReadback> readbacks;  // this frame's
  std::optional<RenderGraph> frame_graph;    // reset and rebuilt every frame

  // Features, created the first time a scene uses their material type.
  // By material type. Features prepare and add their passes in registration order (the
  // order in which they draw into the scene colour), whatever the scene's order.
  std::map<std::string, std::unique_ptr<FeaturePass>, std::less<>> features;
  std::map<std::string, std::vector<std::uint32_t>, std::less<>> feature_objects;
  std::vector<const frame::GpuMesh*> mesh_table;  // by scene mesh index

  // One frame's inputs, kept alive until the graph has executed.
  std::vector<frame::DrawItem> items;          // standard materials: the forward pass
  std::vector<frame::DrawItem> shadow_casters; // every object
  frame::FrameUniforms frame_uniforms;
  std::vector<std::string> warnings;

  FeatureFrame feature_frame(const scene::Scene& scene, std::string_view type, const RenderOptions& options,
                             std::uint32_t w, std::uint32_t h) {
    return FeatureFrame{*device, scene, feature_objects.find(type)->second, mesh_table, frame_uniforms, options.quality, w, h};
  }
  // The material types of this frame's feature objects: registered ones in registration
  // order, then any nobody registered (prepare reports those).
  std::vector<std::string> feature_order() const {
    std::vector<std::string> order;
    for (const auto* d : feature_registry().all())
      if (feature_objects.contains(d->name)) order.push_back(d->name);
    for (const auto& [type, objects] : feature_objects)
      if (std::find(order.begin(), order.end(), type) == order.end()) order.push_back(type);
    return order;
  }
  Result<const pipeline::Pipeline*> choose_pipeline(const scene::Scene& scene, const RenderOptions& options);
  Result<void> ensure_passes(const pipeline::Pipeline& pipeline);
  pipeline::PassFrame pass_frame(const scene::Scene& scene, const RenderOptions& options, bool key_light);
  Result<void> add_readback(RenderGraph& graph, std::string name, TextureHandle handle, bool hdr);
  Result<void> prepare_passes(const scene::Scene& scene, const RenderOptions& options, const pipeline::Pipeline& pipeline,
                              bool key_light) {
    const pipeline::PassFrame frame = pass_frame(scene, options, key_light);
    for (const auto& p : pipeline.passes)
      if (auto ok = instances.at(p.name).pass->prepare(*device, frame); !ok)
        return with_context(weft::format("{}: pass '{}' ({})", pipeline.source, p.name, p.type->name), ok.error());
    return {};
  }
  Result<void> upload_scene(const scene::Scene& scene);
  const gpu::TextureView* material_texture(const scene::Texture& texture, bool srgb, std::string_view material,
                                           std::string_view slot);
  const gpu::Sampler* material_sampler(const scene::TextureSampler& settings);
  frame::MaterialMap material_map(const scene::Texture& texture, bool srgb, std::string_view material, std::string_view slot);
  Result<void> prepare(const scene::Scene& scene, const RenderOptions& options, std::uint32_t w, std::uint32_t h);
  Result<RenderGraph*> build_graph(const scene::Scene& scene, const RenderOptions& options,
                                   const pipeline::Pipeline& pipeline, bool key_light);
};

Result<const pipeline::Pipeline*> Renderer::State::choose_pipeline(const scene::Scene& scene,
                                                                   const RenderOptions& options) {
  if (options.pipeline) return options.pipeline;
  const std::filesystem::path& file = options.pipeline_file.empty() ? scene.pipeline : options.pipeline_file;
  if (!file.empty()) {
    std::error_code ec;
    const auto mtime = std::filesystem::last_write_time(file, ec);
    auto it = pipeline_files.find(file);
    if (it == pipeline_files.end() || ec || it->second.mtime != mtime) {
      auto loaded = pipeline::load_pipeline(file);
      if (!loaded) return std::unexpected(loaded.error());
      it = pipeline_files.insert_or_assign(file, LoadedPipeline{mtime, std::move(*loaded)}).first;
    }
    return &it->second.pipeline;
  }
  if (!default_pipeline) {
    auto loaded = pipeline::default_pipeline();
    if (!loaded) return with_context("the default pipeline", loaded.error());
    default_pipeline.emplace(std::move(*loaded));
  }
  return &*default_pipeline;
}

Result<void> Renderer::State::ensure_passes(const pipeline::Pipeline& pipeline) {
  std::set<std::string, std::less<>> used;
  for (const auto& p : pipeline.passes) {
    used.insert(p.name);
    auto& instance = instances[p.name];
    if (instance.pass && instance.type == p.type && instance.options == p.options) continue;
    auto made = p.type->create(p.options);
    if (!made) return with_context(weft::format("{}: creating pass '{}' ({})", pipeline.source, p.name, p.type->name), made.error());
    instance = {p.type, p.options, std::move(*made)};
    ++stats.pass_creations;
  }
  std::erase_if(instances, [&](const auto& entry) { return !used.contains(entry.first); });
  return {};
}

pipeline::PassFrame Renderer::State::pass_frame(const scene::Scene& scene, const RenderOptions& options, bool key_light) {
  const auto w = std::uint32_t(frame_uniforms.viewport.x), h = std::uint32_t(frame_uniforms.viewport.y);
  return pipeline::PassFrame{
      .device = device,
      .scene = scene,
      .items = items,
      .shadow_casters = shadow_casters,
      .uniforms = frame_uniforms,
      .quality = options.quality,
      .width = w,
      .height = h,
      .key_light = key_light,
      .exposure = options.exposure,
      .aces = options.aces,
      .sample_index = options.sample_index,
      .jitter = frame::sample_jitter(options.sample_index),
      .add_feature_passes =
          [this, &scene, &options, w, h](RenderGraph& graph) -> Result<void> {
        for (const std::string& type : feature_order()) {
          const auto& feature = features.at(type);
          if (auto ok = feature->add_passes(graph, feature_frame(scene, type, options, w, h)); !ok)
            return with_context(weft::format("feature '{}'", feature->name()), ok.error());
        }
        return {};
      },
  };
}

Result<void> Renderer::State::upload_scene(const scene::Scene& scene) {
  for (const auto& mesh : scene.meshes) {
    const auto key = mesh_content_hash(mesh);
    if (meshes.contains(key)) continue;
    auto gpu_mesh = frame::upload_mesh(*device, to_mesh_data(mesh));
    if (!gpu_mesh) return with_context(weft::format("uploading mesh '{}'", mesh.name), gpu_mesh.error());
    meshes.emplace(key, std::move(*gpu_mesh));
    ++stats.mesh_uploads;
  }
  const auto env_key = detail::content_hash(scene.environment);
  if (!environment || env_key != environment_key) {
    const auto texels = detail::environment_texels(scene.environment);
    // A full mip chain: glossy reflections read the level whose texels are as wide as the
    // material's lobe (a rough surface reflects a blurred sky, not a mirror of its texels);
    // the background reads level 0.
    const auto chain = image::rgba32f_mip_chain(std::span(&texels.rgba.front().x, texels.rgba.size() * 4), texels.width,
                                                texels.height);
    auto t = device->create_texture({.label = "environment", .size = {texels.width, texels.height, 1},
                                     .format = gpu::Format::RGBA32Float,
                                     .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst,
                                     .mip_level_count = std::uint32_t(chain.size())});
    if (!t) return std::unexpected(t.error());
    std::vector<std::span<const std::byte>> levels;
    for (const auto& level : chain) levels.push_back(std::as_bytes(std::span(level)));
    if (auto ok = device->queue().write_texture_levels(*t, levels); !ok) return ok;
    environment.emplace(std::move(*t));
    // The SH include the rotation; a constant sky gets its exact SH (a 4x2 grid is too coarse
    // a quadrature for bands 1 and 2).
    environment_sh = scene.environment.map
                         ? frame::irradiance_sh(texels.rgb, texels.width, texels.height,
                                                glm::radians(scene.environment.rotation_degrees))
                         : frame::constant_irradiance_sh(scene.environment.constant_color);
    environment_key = env_key;
    ++stats.environment_uploads;
  }
  return {};
}

// A material's map as a texture (sRGB-decoded for colour, linear for data), loaded once per
// source; a map that cannot be loaded or decoded is a warning naming the material and the
// slot, and the material is drawn as if it had none.
const gpu::TextureView* Renderer::State::material_texture(const scene::Texture& texture, bool srgb,
                                                          std::string_view material, std::string_view slot) {
  // A declared frame draws nothing: material maps are bound per draw, not resources of the
  // graph, so they are not read at all.
  if (texture.empty() || device->declaring()) return nullptr;
  // The content decides the mip chain, so a file used as a normal map is a texture of its own.
  std::string key = srgb ? "srgb:" : slot == "normal map" ? "normal:" : "linear:";
  if (!texture.path.empty()) {
    key += texture.path.string();
  } else {
    Hasher h;
    h.bytes(texture.encoded.data(), texture.encoded.size());
    key += weft::format("embedded:{:016x}", h.digest());
  }
  auto it = textures.find(key);
  if (it == textures.end()) {
    std::optional<gpu::Texture> loaded;
    auto pixels = texture.path.empty()
                      ? image::decode_ldr(texture.encoded, texture.label.empty() ? std::string("(embedded)") : texture.label)
                      : image::load_ldr(texture.path);
    if (!pixels) {
      warnings.push_back(weft::format("material '{}' {}: {}; drawn without it", material, slot, pixels.error().message));
    } else {
      std::vector<std::uint8_t> rgba(std::size_t(pixels->width) * pixels->height * 4, 255);
      for (std::size_t i = 0; i < std::size_t(pixels->width) * pixels->height; ++i)
        for (std::uint32_t c = 0; c < std::min(pixels->channels, 3u); ++c)
          rgba[i * 4 + c] = pixels->pixels[i * pixels->channels + (pixels->channels < 3 ? 0 : c)];
      if (pixels->channels < 3)
        for (std::size_t i = 0; i < std::size_t(pixels->width) * pixels->height; ++i) rgba[i * 4 + 1] = rgba[i * 4 + 2] = rgba[i * 4];
      // The whole mip chain, made here: minified maps are filtered, not point-sampled
      // (sRGB colour averaged in linear light, normal maps renormalised).
      const auto chain = image::rgba8_mip_chain(rgba, pixels->width, pixels->height,
                                                srgb                 ? image::MipContent::Srgb
                                                : slot == "normal map" ? image::MipContent::NormalMap
                                                                       : image::MipContent::Linear);
      std::vector<std::span<const std::byte>> levels;
      for (const auto& level : chain) levels.push_back(std::as_bytes(std::span(level)));
      auto t = device->create_texture({.label = key, .size = {pixels->width, pixels->height, 1},
                                       .format = srgb ? gpu::Format::RGBA8Srgb : gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst,
                                       .mip_level_count = std::uint32_t(chain.size())});
      if (t && device->queue().write_texture_levels(*t, levels)) {
        loaded.emplace(std::move(*t));
        ++stats.texture_uploads;
      } else {
        warnings.push_back(weft::format("material '{}' {}: could not upload '{}'", material, slot, key));
      }
    }
    it = textures.emplace(key, std::move(loaded)).first;
  }
  return it->second ? &it->second->view() : nullptr;
}

const gpu::Sampler* Renderer::State::material_sampler(const scene::TextureSampler& settings) {
  for (const auto& [s, sampler] : samplers)
    if (s == settings) return &sampler;
  const auto address = [](scene::TextureWrap w) {
    return w == scene::TextureWrap::Repeat        ? gpu::AddressMode::Repeat
           : w == scene::TextureWrap::ClampToEdge ? gpu::AddressMode::ClampToEdge
                                                  : gpu::AddressMode::MirrorRepeat;
  };
  const auto filter = [](scene::TextureFilter f) {
    return f == scene::TextureFilter::Linear ? gpu::FilterMode::Linear : gpu::FilterMode::Nearest;
  };
  const bool linear = settings.mag_filter == scene::TextureFilter::Linear && settings.min_filter == scene::TextureFilter::Linear;
  auto sampler = device->create_sampler({.label = "material-sampler",
                                         .mag_filter = filter(settings.mag_filter),
                                         .min_filter = filter(settings.min_filter),
                                         .address_mode = address(settings.wrap_u),
                                         .address_mode_v = address(settings.wrap_v),
                                         // Trilinear, and anisotropic where the adapter has it.
                                         .max_anisotropy = linear ? 16.0f : 1.0f});
  if (!sampler) {
    warnings.push_back(weft::format("material sampler: {}", sampler.error().message));
    return nullptr;
  }
  samplers.emplace_back(settings, std::move(*sampler));
  return &samplers.back().second;
}

frame::MaterialMap Renderer::State::material_map(const scene::Texture& texture, bool srgb, std::string_view material,
                                                 std::string_view slot) {
  frame::MaterialMap map;
  map.view = material_texture(texture, srgb, material, slot);
  if (!map.view) return map;
  map.sampler = material_sampler(texture.sampler);
  map.texcoord = texture.texcoord;
  return map;
}

Result<void> Renderer::State::prepare(const scene::Scene& scene, const RenderOptions& options, std::uint32_t w,
                                      std::uint32_t h) {
  warnings.clear();
  items.clear();
  shadow_casters.clear();
  feature_objects.clear();
  mesh_table.clear();
  for (const auto& mesh : scene.meshes) mesh_table.push_back(&meshes.at(mesh_content_hash(mesh)));
  const scene::DirectionalLight* key_light = nullptr;
  for (const auto& light : scene.lights)
    if (const auto* d = std::get_if<scene::DirectionalLight>(&light); d && !key_light) key_light = d;
  const std::vector<bool> casts = key_light ? select_shadow_casters(scene, -key_light->direction) : std::vector<bool>{};
  for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
    const auto& object = scene.objects[i];
    const auto& material = scene.materials.at(object.material);
    frame::DrawItem item{.mesh = mesh_table.at(object.mesh), .model = object.transform};
    const auto& s = material.standard;
    item.material = {.base_color = s.base_color, .metallic = s.metallic, .roughness = s.roughness, .emissive = s.emissive,
                     .normal_scale = s.normal_scale, .occlusion_strength = s.occlusion_strength};
    // A floor under everything shadows nothing and covered most of the shadow map.
    if (!key_light || casts[i]) shadow_casters.push_back(item);
    if (material.type != scene::standard_material) {
      feature_objects[material.type].push_back(i);
      continue;
    }
    item.maps = {material_map(s.base_color_texture, true, material.name, "base colour map"),
                 material_map(s.metallic_roughness_texture, false, material.name, "metallic-roughness map"),
                 material_map(s.normal_texture, false, material.name, "normal map"),
                 material_map(s.occlusion_texture, false, material.name, "occlusion map"),
                 material_map(s.emissive_texture, true, material.name, "emissive map")};
    item.base_color_texture = item.maps[0].view;
    items.push_back(item);
  }
  std::sort(warnings.begin(), warnings.end());
  warnings.erase(std::unique(warnings.begin(), warnings.end()), warnings.end());

  // The first directional light is the key light (it casts the shadow map); every other
  // light is a punctual light of the standard material, unshadowed.
  const scene::DirectionalLight* key = nullptr;
  frame::FrameUniforms& lights_out = frame_uniforms;
  std::uint32_t light_count = 0;
  for (const auto& light : scene.lights) {
    const auto* d = std::get_if<scene::DirectionalLight>(&light);
    if (d && !key) {
      key = d;
      continue;
    }
    if (light_count == frame::max_punctual_lights) {
      warnings.push_back(weft::format("the scene has more than {} lights besides the key light; the rest are not shaded",
                                      frame::max_punctual_lights));
      break;
    }
    frame::PunctualLight& out = lights_out.lights[light_count++];
    out = {};
    if (d) {
      out.direction_type = vec4(glm::normalize(d->direction), 2.0f);
      out.color = vec4(d->color * d->intensity, 0.0f);
    } else if (const auto* p = std::get_if<scene::PointLight>(&light)) {
      out.position_range = vec4(p->position, p->range);
      out.direction_type = vec4(0.0f, -1.0f, 0.0f, 0.0f);
      out.color = vec4(p->color * p->intensity, 0.0f);
    } else if (const auto* sp = std::get_if<scene::SpotLight>(&light)) {
      const float cos_outer = std::cos(glm::radians(sp->outer_cone_degrees));
      const float cos_inner = std::cos(glm::radians(sp->inner_cone_degrees));
      const float scale = 1.0f / std::max(cos_inner - cos_outer, 1e-4f);
      out.position_range = vec4(sp->position, sp->range);
      out.direction_type = vec4(glm::normalize(sp->direction), 1.0f);
      out.color = vec4(sp->color * sp->intensity, 0.0f);
      out.cone = vec4(scale, -cos_outer * scale, 0.0f, 0.0f);
    }
  }
  lights_out.light_count = vec4(float(light_count), 0.0f, 0.0f, 0.0f);
  if (light_count > 0 && !feature_objects.empty())
    warnings.push_back("point, spot and extra directional lights are shaded by standard materials only; feature "
                       "materials see the key light and the environment");

  frame::FrameUniforms& u = frame_uniforms;
  const auto& cam = scene.camera;
  u.view = cam.view();
  u.projection = frame::jitter_projection(cam.projection(float(w) / float(h)),
                                          frame::sample_jitter(options.sample_index), w, h);
  u.view_projection = u.projection * u.view;
  u.inverse_view_projection = glm::inverse(u.view_projection);
  u.camera_position = vec4(cam.position, 1.0f);
  if (key) {
    const vec3 towards = -glm::normalize(key->direction);
    const auto bounds = scene.bounds();
    u.light_direction = vec4(towards, 0.0f);
    u.light_color = vec4(key->color * key->intensity, 0.0f);
    u.light_view_projection = frame::fit_light_view_projection(towards, bounds.min, bounds.max);
  } else {
    u.light_direction = vec4(0, 1, 0, 0);
    u.light_color = vec4(0.0f);
    u.light_view_projection = mat4(1.0f);
  }
  u.environment = vec4(scene.environment.intensity, glm::radians(scene.environment.rotation_degrees), 1.0f, 0.0f);
  u.viewport = vec4(float(w), float(h), 1.0f / float(w), 1.0f / float(h));
  u.irradiance_sh = environment_sh;
  (void)options;

  if (!uniforms) {
    auto b = device->create_buffer({.label = "frame_uniforms", .size = sizeof(frame::FrameUniforms),
                                    .usage = gpu::BufferUsage::Uniform | gpu::BufferUsage::CopyDst});
    if (!b) return std::unexpected(b.error());
    uniforms.emplace(std::move(*b));
  }
  if (auto ok = device->queue().write_buffer(*uniforms, 0, std::as_bytes(std::span(&u, 1))); !ok) return ok;
  for (const std::string& type : feature_order()) {
    const auto& objects = feature_objects.at(type);
    auto& feature = features[type];
    if (!feature) {
      // A scene file's types were checked against the registry when it was read; a scene
      // built in code may name a type nobody registered.
      const FeatureDescriptor* descriptor = feature_registry().find(type);
      if (!descriptor)
        return fail(ErrorKind::NotFound, "material type '{}' (object '{}'): no feature of that name is registered; "
                    "registered: {}", type, scene.objects.at(objects.front()).name, feature_registry().names());
      auto created = descriptor->create(*device);
      if (!created) return with_context(weft::format("creating the {} feature", type), created.error());
      feature = std::move(*created);
      ++stats.pass_creations;
    }
    if (auto ok = feature->prepare(feature_frame(scene, type, options, w, h)); !ok) return ok;
    for (auto& message : feature->warnings()) warnings.push_back(std::move(message));
  }
  if (options.target) {
    // The caller's texture (the viewer's presentable target): the frame's image goes there,
    // and nothing is read back.
    const auto& t = *options.target;
    if (t.size().width != w || t.size().height != h || t.format() != gpu::Format::RGBA8Unorm ||
        !gpu::has(t.usage(), gpu::TextureUsage::ColorAttachment))
      return fail(ErrorKind::InvalidArgument, "render target '{}' is {}x{} {} ({}); the frame needs {}x{} rgba8unorm with "
                  "color-attachment usage", t.label(), t.size().width, t.size().height, gpu::to_string(t.format()),
                  gpu::to_string(t.usage()), w, h);
  } else if (!output || output->size().width != w || output->size().height != h) {
    output.reset();
    auto t = device->create_texture({.label = "output", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                     .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
    if (!t) return std::unexpected(t.error());
    output.emplace(std::move(*t));
  }
  return {};
}

// A copy of `handle` into a host-visible buffer after the pass that made it, read back once
// the frame has executed.
Result<void> Renderer::State::add_readback(RenderGraph& graph, std::string name, TextureHandle handle, bool hdr) {
  auto desc = graph.texture_desc(handle);
  if (!desc) return fail(ErrorKind::InvalidArgument, "'{}' is not a texture of this frame", name);
  if (desc->sample_count > 1) {  // copies read one value per texel: resolve first
    WEFT_TRY(handle, frame::add_resolve_pass(graph, weft::format("resolve {} (read back)", name), handle));
    desc = graph.texture_desc(handle);
  }
  const gpu::Extent3D size = desc->size.resolve({std::uint32_t(frame_uniforms.viewport.x), std::uint32_t(frame_uniforms.viewport.y), 1});
  const auto& info = gpu::format_info(desc->format);
  if (desc->dimension != gpu::TextureDimension::D2 || size.depth_or_layers != 1)
    return fail(ErrorKind::Unsupported, "'{}' is not a single 2D image; only those can be read back", name);
  if (desc->format == gpu::Format::Depth24PlusStencil8)
    return fail(ErrorKind::Unsupported, "'{}' is {}; its depth cannot be copied out as such", name, info.name);
  const std::uint64_t bytes = std::uint64_t(size.width) * size.height * info.bytes_per_texel;
  const std::string label = hdr ? std::string("hdr_readback") : "readback:" + name;
  auto it = readback_buffers.find(label);
  if (it == readback_buffers.end() || it->second.size() != bytes) {
    if (it != readback_buffers.end()) readback_buffers.erase(it);
    auto b = device->create_buffer({.label = label, .size = bytes, .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::MapRead});
    if (!b) return std::unexpected(b.error());
    it = readback_buffers.emplace(label, std::move(*b)).first;
  }
  struct Copy {
    TextureHandle source;
    BufferHandle target;
  };
  const BufferHandle target = graph.import_buffer(label, &it->second, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Copy>(
      label,
      [&](PassBuilder& b, Copy& d) {
        d.source = b.read(handle, TextureUse::CopySrc);
        d.target = b.write(target, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Copy& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.source), res.buffer(d.target), 0);
      });
  graph.mark_output(copy.target, gpu::Access::HostRead);
  readbacks.push_back({std::move(name), desc->format, size.width, size.height, &it->second, hdr});
  return {};
}

Result<RenderGraph*> Renderer::State::build_graph(const scene::Scene& scene, const RenderOptions& options,
                                                  const pipeline::Pipeline& pipeline, bool key_light) {
  // One graph, reset and refilled every frame: its arrays, arena and compile state are reused
  // (RenderGraph::reset), so a steady frame's setup and compile allocate next to nothing.
  if (frame_graph)
    frame_graph->reset();
  else
    frame_graph.emplace("frame");
  RenderGraph& graph = *frame_graph;
  readbacks.clear();
  auto& board = graph.blackboard();
  frame::put_scene_targets(
      board, {.uniforms = graph.import_buffer("frame_uniforms", &*uniforms, gpu::Access::UniformRead),
              .environment = graph.import_texture("environment", &*environment, gpu::Access::ShaderRead)});

  // What to read back after which pass: the HDR image the frame's image is made from, and the
  // slots the caller named ("pass.slot"); other names are looked up once every pass is in.
  const pipeline::SlotRef& image = pipeline.outputs.front();
  std::optional<pipeline::SlotRef> hdr_source;
  if (options.read_hdr) {
    const pipeline::PipelinePass* maker = pipeline.find(image.pass);
    for (const auto& in : maker->type->inputs)
      if (in.linear_source) hdr_source = pipeline.source_of({image.pass, in.name});
    if (!hdr_source)
      return fail(ErrorKind::InvalidArgument, "{}: the frame's image '{}' is not made from a linear HDR input (its pass has "
                  "none marked), so there is no HDR image to read back; name one with --output PASS.SLOT",
                  pipeline.source, image.text());
  }
  std::vector<std::string> by_name;
  std::vector<std::pair<std::string, pipeline::SlotRef>> by_slot;
  for (const auto& name : options.outputs) {
    auto ref = pipeline::parse_slot_ref(name);
    const pipeline::PipelinePass* p = ref ? pipeline.find(ref->pass) : nullptr;
    if (p && pipeline::find_output(*p->type, ref->slot))
      by_slot.emplace_back(name, *ref);
    else
      by_name.push_back(name);
  }

  const pipeline::PassFrame frame = pass_frame(scene, options, key_light);
  std::map<std::string, TextureHandle> produced;  // "pass.slot" -> this frame's handle
  // Falcor's automatic MSAA resolve: a multisampled output feeding an input that reads texels
  // (Slot::multisampled false) is resolved once per texture version, shared by its readers.
  std::map<std::pair<std::uint32_t, std::uint32_t>, TextureHandle> resolved;
  auto single_sample = [&](const std::string& from, TextureHandle handle) -> Result<TextureHandle> {
    const auto desc = graph.texture_desc(handle);
    if (!desc || desc->sample_count == 1) return handle;
    auto [it, fresh] = resolved.try_emplace({handle.index, handle.version});
    if (fresh) {
      auto r = frame::add_resolve_pass(graph, "resolve " + from, handle);
      if (!r) {
        resolved.erase(it);
        return std::unexpected(r.error());
      }
      it->second = *r;
    }
    return it->second;
  };
  for (const auto& p : pipeline.passes) {
    std::vector<pipeline::PassSlots::Binding> inputs, targets;
    for (const auto& in : p.type->inputs) {
      const auto from = pipeline.source_of({p.name, in.name});
      if (!from) continue;
      TextureHandle handle = produced[from->text()];
      if (!handle && !in.optional)
        return fail(ErrorKind::Graph, "{}: pass '{}' input '{}': '{}' produced nothing this frame", pipeline.source, p.name,
                    in.name, from->text());
      if (handle && !in.multisampled) {
        WEFT_TRY(handle, single_sample(from->text(), handle));
      }
      inputs.push_back({in.name, handle});
    }
    if (p.name == image.pass)
      targets.push_back({image.slot, graph.import_texture("output", options.target ? options.target : &*output,
                                                          gpu::Access::Undefined)});
    pipeline::PassSlots slots(p.name, std::move(inputs), std::move(targets));
    if (auto ok = instances.at(p.name).pass->add(graph, frame, slots); !ok)
      return with_context(weft::format("{}: pass '{}' ({})", pipeline.source, p.name, p.type->name), ok.error());
    for (const auto& out : p.type->outputs) produced[p.name + "." + out.name] = slots.output(out.name);
    for (const auto& out : p.type->outputs) {
      const pipeline::SlotRef ref{p.name, out.name};
      const TextureHandle handle = slots.output(out.name);
      if (hdr_source && *hdr_source == ref && handle)
        if (auto ok = add_readback(graph, ref.text(), handle, true); !ok) return std::unexpected(ok.error());
      for (const auto& [name, wanted] : by_slot) {
        if (!(wanted == ref)) continue;
        if (!handle) return fail(ErrorKind::NotFound, "--output {}: the pass made nothing there this frame", name);
        if (auto ok = add_readback(graph, name, handle, false); !ok) return with_context("--output " + name, ok.error());
      }
    }
  }
  for (const auto& name : by_name) {
    const TextureHandle handle = graph.find_texture(name);
    if (!handle) {
      for (std::uint32_t i = 0; i < graph.resource_count(); ++i)
        if (graph.resource_name(i) == name)
          return fail(ErrorKind::Unsupported, "--output '{}': that resource is a buffer; only textures are written as "
                      "images", name);
      std::set<std::string> names;
      for (std::uint32_t i = 0; i < graph.resource_count(); ++i) names.insert(std::string(graph.resource_name(i)));
      std::string slots, resources;
      for (const auto& p : pipeline.passes)
        for (const auto& out : p.type->outputs) slots += (slots.empty() ? "" : ", ") + p.name + "." + out.name;
      for (const auto& n : names) resources += (resources.empty() ? "" : ", ") + n;
      return fail(ErrorKind::NotFound, "--output '{}': no pass slot or resource of this frame has that name (slots: {}; "
                  "resources: {})", name, slots, resources);
    }
    if (auto ok = add_readback(graph, name, handle, false); !ok) return with_context("--output " + name, ok.error());
  }
  TextureHandle out = produced[image.text()];
  if (!out) return fail(ErrorKind::Graph, "{}: the frame's image '{}' was not produced", pipeline.source, image.text());
  WEFT_TRY(out, single_sample(image.text(), out));
  graph.mark_output(out, options.target ? options.target_final_state : gpu::Access::CopySrc);
  for (std::size_t i = 1; i < pipeline.outputs.size(); ++i)
    if (const TextureHandle extra = produced[pipeline.outputs[i].text()]) graph.mark_output(extra);
  return &graph;
}

Result<Renderer> Renderer::create(gpu::Device& device) {
  Renderer r;
  r.state_ = std::make_unique<State>();
  r.state_->device = &device;
  return r;
}

Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;
Renderer::~Renderer() = default;

Renderer::CacheStats Renderer::cache_stats() const { return state_->stats; }

namespace {
bool has_key_light(const scene::Scene& scene) {
  return std::any_of(scene.lights.begin(), scene.lights.end(),
                     [](const scene::Light& l) { return std::holds_alternative<scene::DirectionalLight>(l); });
}

Result<std::pair<std::uint32_t, std::uint32_t>> frame_size(const scene::Scene& scene, const RenderOptions& options) {
  // A camera with NaN or infinity (a scene built in code, a viewer's pose) would give NaN
  // matrices to every pass: refused, naming the field (a scene file's camera is checked when read).
  const scene::Camera& c = scene.camera;
  const auto finite = [](vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  for (const auto& [field, v] : {std::pair{"position", c.position}, std::pair{"target", c.target}, std::pair{"up", c.up}})
    if (!finite(v)) return fail(ErrorKind::InvalidArgument, "scene camera: {} ({}, {}, {}) is not finite", field, v.x, v.y, v.z);
  for (const auto& [field, v] : {std::pair{"fov", c.fov_y_degrees}, std::pair{"near", c.near}, std::pair{"far", c.far}})
    if (!std::isfinite(v)) return fail(ErrorKind::InvalidArgument, "scene camera: {} {} is not finite", field, v);
  const std::uint32_t w = options.width ? options.width : scene.output.width;
  const std::uint32_t h = options.height ? options.height : scene.output.height;
  if (w == 0 || h == 0 || w > scene::max_output_side || h > scene::max_output_side)
    return fail(ErrorKind::InvalidArgument, "output size {}x{} must be within 1..{} on each side", w, h, scene::max_output_side);
  return std::pair{w, h};
}
}  // namespace

Result<GraphReport> describe(const scene::Scene& scene, const RenderOptions& options,
                             const std::function<void(const CompiledGraph&)>& inspect) {
  gpu::Device device = gpu::Device::create_declaring("describe");
  auto renderer = Renderer::create(device);
  if (!renderer) return std::unexpected(renderer.error());
  return renderer->describe(scene, options, inspect);
}

Result<GraphReport> Renderer::describe(const scene::Scene& scene, const RenderOptions& options,
                                       const std::function<void(const CompiledGraph&)>& inspect) {
  auto size = frame_size(scene, options);
  if (!size) return std::unexpected(size.error());
  const bool key = has_key_light(scene);
  auto& s = *state_;
  auto pipeline = s.choose_pipeline(scene, options);
  if (!pipeline) return std::unexpected(pipeline.error());
  if (auto ok = s.ensure_passes(**pipeline); !ok) return std::unexpected(ok.error());
  if (auto ok = s.upload_scene(scene); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare(scene, options, size->first, size->second); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare_passes(scene, options, **pipeline, key); !ok) return std::unexpected(ok.error());
  auto built = s.build_graph(scene, options, **pipeline, key);
  if (!built) return std::unexpected(built.error());
  auto compiled = (*built)->compile({.output_extent = {size->first, size->second, 1}, .device = s.device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  if (inspect) inspect(*compiled);
  GraphReport report{compiled->to_dot(), compiled->dump(), {}, {}};
  for (auto index : compiled->order()) report.passes.emplace_back(compiled->passes()[index].name);
  for (const auto& p : compiled->passes())
    if (p.culled) report.culled_passes.emplace_back(p.name);
  for (const auto& r : compiled->resources()) report.resources.emplace_back(r.name);
  for (const auto& p : (*pipeline)->passes)
    for (const auto& out : p.type->outputs) report.slots.push_back(p.name + "." + out.name);
  report.pipeline = pipeline::to_json(**pipeline);
  report.warnings = (*pipeline)->warnings;
  return report;
}

namespace {
// Readback bytes as linear RGBA floats: colour formats by channel (8-bit unorm scaled to
// 0..1, sRGB decoded), depth in the red channel.
image::Image to_float_rgba(const std::vector<std::byte>& bytes, gpu::Format format, std::uint32_t w, std::uint32_t h) {
  image::Image out = image::Image::filled(w, h, 4);
  const auto& info = gpu::format_info(format);
  const std::size_t n = std::size_t(w) * h;
  for (std::size_t i = 0; i < n; ++i) {
    const std::byte* texel = bytes.data() + i * info.bytes_per_texel;
    float v[4] = {0, 0, 0, 1};
    for (std::uint32_t c = 0; c < info.components && c < 4; ++c) {
      switch (format) {
        case gpu::Format::R8Unorm: case gpu::Format::RG8Unorm: case gpu::Format::RGBA8Unorm: case gpu::Format::RGBA8Srgb:
          v[c] = float(std::to_integer<std::uint8_t>(texel[c])) / 255.0f;
          if (format == gpu::Format::RGBA8Srgb && c < 3) v[c] = image::srgb_to_linear(v[c]);
          break;
        case gpu::Format::BGRA8Unorm:
          v[c] = float(std::to_integer<std::uint8_t>(texel[c == 3 ? 3 : 2 - c])) / 255.0f;
          break;
        case gpu::Format::R16Float: case gpu::Format::RG16Float: case gpu::Format::RGBA16Float: {
          std::uint16_t half;
          std::memcpy(&half, texel + 2 * c, 2);
          v[c] = glm::unpackHalf1x16(half);
          break;
        }
        case gpu::Format::R32Float: case gpu::Format::RG32Float: case gpu::Format::RGBA32Float: case gpu::Format::Depth32Float:
          std::memcpy(&v[c], texel + 4 * c, 4);
          break;
        case gpu::Format::R32Uint: case gpu::Format::RGBA32Uint: {
          std::uint32_t u;
          std::memcpy(&u, texel + 4 * c, 4);
          v[c] = float(u);
          break;
        }
        case gpu::Format::Depth16Unorm: {
          std::uint16_t d;
          std::memcpy(&d, texel, 2);
          v[c] = float(d) / 65535.0f;
          break;
        }
        default: break;
      }
    }
    if (info.components == 1 && !info.depth) v[1] = v[2] = v[0];  // one channel shows as grey
    for (int c = 0; c < 4; ++c) out.pixels[i * 4 + c] = v[c];
  }
  return out;
}
}  // namespace

image::Image8 picture(const Readback& r) {
  const auto& info = gpu::format_info(r.format);
  const std::size_t n = std::size_t(r.pixels.width) * r.pixels.height;
  image::Image8 out = image::Image8::filled(r.pixels.width, r.pixels.height, 4);
  float lo = 1.0f, hi = 0.0f;
  if (info.depth)
    for (std::size_t i = 0; i < n; ++i)
      if (const float d = r.pixels.pixels[i * 4]; d < 1.0f) lo = std::min(lo, d), hi = std::max(hi, d);
  const bool raw = !info.depth && info.bytes_per_texel == info.components && !info.srgb;  // 8-bit unorm
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 4; ++c) {
      float v = r.pixels.pixels[i * 4 + c];
      if (info.depth) {
        const float d = r.pixels.pixels[i * 4];
        v = c == 3 ? 1.0f : d >= 1.0f ? 0.0f : hi > lo ? 1.0f - 0.85f * (d - lo) / (hi - lo) : 1.0f;
      } else if (!raw && c < 3) {
        v = image::linear_to_srgb(std::clamp(v, 0.0f, 1.0f));
      }
      out.pixels[i * 4 + c] = std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
    }
  return out;
}

Result<const pipeline::Pipeline*> Renderer::pipeline_for(const scene::Scene& scene, const RenderOptions& options) {
  return state_->choose_pipeline(scene, options);
}

Result<Frame> Renderer::render(const scene::Scene& scene, const RenderOptions& options) {
  auto size = frame_size(scene, options);
  if (!size) return std::unexpected(size.error());
  const auto [w, h] = *size;
  const bool key = has_key_light(scene);
  auto& s = *state_;
  if (s.device->declaring())
    return fail(ErrorKind::Unsupported, "this renderer's device ('{}') has no adapter: it declares and compiles frames "
                "(describe) but renders none", s.device->adapter_info().name);
  auto pipeline = s.choose_pipeline(scene, options);
  if (!pipeline) return std::unexpected(pipeline.error());
  if (auto ok = s.ensure_passes(**pipeline); !ok) return std::unexpected(ok.error());
  if (auto ok = s.upload_scene(scene); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare(scene, options, w, h); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare_passes(scene, options, **pipeline, key); !ok) return std::unexpected(ok.error());
  auto built = s.build_graph(scene, options, **pipeline, key);
  if (!built) return std::unexpected(built.error());
  auto compiled = (*built)->compile({.output_extent = {w, h, 1}, .device = s.device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  ++(compiled->plan_reused() ? s.stats.graph_plans_reused : s.stats.graph_plans);
  auto stats = compiled->execute(*s.device, {.timestamps = options.timestamps, .serial_passes = options.serial_passes});
  if (!stats) return std::unexpected(stats.error());
  Frame frame;
  if (!options.target) {
    auto pixels = s.device->queue().read_texture(*s.output);
    if (!pixels) return std::unexpected(pixels.error());
    frame.image = image::Image8::filled(w, h, 4);
    std::memcpy(frame.image.pixels.data(), pixels->data(), frame.image.pixels.size());
  }
  for (const auto& r : s.readbacks) {
    auto bytes = s.device->queue().read_buffer(*r.buffer);
    if (!bytes) return std::unexpected(bytes.error());
    if (r.hdr) {
      frame.hdr = to_float_rgba(*bytes, r.format, r.width, r.height);
      continue;
    }
    frame.outputs.push_back({r.name, r.format, to_float_rgba(*bytes, r.format, r.width, r.height)});
  }
  frame.stats = std::move(*stats);
  for (auto index : compiled->order()) frame.passes.emplace_back(compiled->passes()[index].name);
  frame.warnings = s.warnings;
  for (const auto& w2 : (*pipeline)->warnings) frame.warnings.push_back(w2);
  return frame;
}

}  // namespace weft::renderer
