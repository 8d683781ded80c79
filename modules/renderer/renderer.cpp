module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
module weft.renderer;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.base_pass.shadow;
import weft.base_pass.forward;
import weft.base_pass.background;
import weft.base_pass.tonemap;

namespace weft::renderer {

namespace {
std::uint32_t shadow_resolution(Quality q) {
  switch (q) {
    case Quality::Low: return 1024;
    case Quality::Medium: return 2048;
    case Quality::High: return 4096;
    case Quality::Reference: return 8192;
  }
  return 2048;
}
}  // namespace

struct Renderer::State {
  gpu::Device* device = nullptr;
  CacheStats stats;
  std::optional<passes::ShadowPass> shadow;
  std::optional<passes::ForwardPass> forward;
  std::optional<passes::BackgroundPass> background;
  std::optional<passes::TonemapPass> tonemap;
  std::unordered_map<std::uint64_t, frame::GpuMesh> meshes;
  // Material maps by source and colour space ("srgb:" / "linear:" + path, or a hash of
  // embedded bytes); empty = failed to load. Samplers by their glTF settings.
  std::unordered_map<std::string, std::optional<gpu::Texture>> textures;
  std::vector<std::pair<scene::TextureSampler, gpu::Sampler>> samplers;
  std::uint64_t environment_key = 0;
  std::optional<gpu::Texture> environment;
  std::array<vec4, 9> environment_sh{};
  std::optional<gpu::Texture> no_shadow;  // 1x1 depth 1.0 when the scene has no key light
  std::optional<gpu::Buffer> uniforms;
  std::optional<gpu::Texture> output;
  std::optional<gpu::Buffer> hdr_readback;  // RenderOptions::read_hdr: the scene colour, RGBA16F
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
  Result<void> ensure_passes(bool key_light, Quality quality);
  Result<void> upload_scene(const scene::Scene& scene);
  const gpu::TextureView* material_texture(const scene::Texture& texture, bool srgb, std::string_view material,
                                           std::string_view slot);
  const gpu::Sampler* material_sampler(const scene::TextureSampler& settings);
  frame::MaterialMap material_map(const scene::Texture& texture, bool srgb, std::string_view material, std::string_view slot);
  Result<void> prepare(const scene::Scene& scene, const RenderOptions& options, std::uint32_t w, std::uint32_t h);
  Result<std::pair<RenderGraph*, TextureHandle>> build_graph(const scene::Scene& scene, const RenderOptions& options,
                                                            bool key_light);
};

Result<void> Renderer::State::ensure_passes(bool key_light, Quality quality) {
  auto create = [&](auto& slot, auto make) -> Result<void> {
    if (slot) return {};
    auto pass = make();
    if (!pass) return std::unexpected(pass.error());
    slot.emplace(std::move(*pass));
    ++stats.pass_creations;
    return {};
  };
  const std::uint32_t resolution = std::min(shadow_resolution(quality), device->adapter_info().limits.max_texture_dimension_2d);
  if (key_light && shadow && shadow->settings().resolution != resolution) shadow.reset();
  if (key_light)
    if (auto ok = create(shadow, [&] { return passes::ShadowPass::create(*device, {.resolution = resolution}); }); !ok) return ok;
  if (auto ok = create(forward, [&] { return passes::ForwardPass::create(*device); }); !ok) return ok;
  if (auto ok = create(background, [&] { return passes::BackgroundPass::create(*device); }); !ok) return ok;
  if (auto ok = create(tonemap, [&] { return passes::TonemapPass::create(*device); }); !ok) return ok;
  if (!key_light && !no_shadow) {
    auto t = device->create_texture({.label = "no_shadow", .size = {1, 1, 1}, .format = gpu::Format::Depth32Float,
                                     .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
    if (!t) return std::unexpected(t.error());
    const float far_depth = 1.0f;
    if (auto ok = device->queue().write_texture(*t, std::as_bytes(std::span(&far_depth, 1))); !ok) return ok;
    no_shadow.emplace(std::move(*t));
  }
  return {};
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
    auto t = device->create_texture({.label = "environment", .size = {texels.width, texels.height, 1},
                                     .format = gpu::Format::RGBA32Float,
                                     .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
    if (!t) return std::unexpected(t.error());
    if (auto ok = device->queue().write_texture(*t, std::as_bytes(std::span(texels.rgba))); !ok) return ok;
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
  if (texture.empty()) return nullptr;
  std::string key = srgb ? "srgb:" : "linear:";
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
      auto t = device->create_texture({.label = key, .size = {pixels->width, pixels->height, 1},
                                       .format = srgb ? gpu::Format::RGBA8Srgb : gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
      if (t && device->queue().write_texture(*t, std::as_bytes(std::span(rgba)))) {
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
  auto sampler = device->create_sampler({.label = "material-sampler",
                                         .mag_filter = filter(settings.mag_filter),
                                         .min_filter = filter(settings.min_filter),
                                         .address_mode = address(settings.wrap_u),
                                         .address_mode_v = address(settings.wrap_v)});
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
  u.projection = cam.projection(float(w) / float(h));
  u.view_projection = u.projection * u.view;
  u.inverse_view_projection = glm::inverse(u.view_projection);
  u.camera_position = vec4(cam.position, 1.0f);
  if (key) {
    const vec3 towards = -glm::normalize(key->direction);
    const auto bounds = scene.bounds();
    u.light_direction = vec4(towards, 0.0f);
    u.light_color = vec4(key->color * key->intensity, 0.0f);
    u.light_view_projection = passes::fit_light_view_projection(towards, bounds.min, bounds.max);
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
  if (!output || output->size().width != w || output->size().height != h) {
    output.reset();
    auto t = device->create_texture({.label = "output", .size = {w, h, 1}, .format = passes::output_format,
                                     .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
    if (!t) return std::unexpected(t.error());
    output.emplace(std::move(*t));
  }
  const std::uint64_t hdr_bytes = std::uint64_t(w) * h * 8;  // RGBA16F
  if (options.read_hdr && (!hdr_readback || hdr_readback->size() != hdr_bytes)) {
    hdr_readback.reset();
    auto b = device->create_buffer(
        {.label = "hdr_readback", .size = hdr_bytes, .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::MapRead});
    if (!b) return std::unexpected(b.error());
    hdr_readback.emplace(std::move(*b));
  }
  return {};
}

Result<std::pair<RenderGraph*, TextureHandle>> Renderer::State::build_graph(const scene::Scene& scene,
                                                                            const RenderOptions& options, bool key_light) {
  // One graph, reset and refilled every frame: its arrays, arena and compile state are reused
  // (RenderGraph::reset), so a steady frame's setup and compile allocate next to nothing.
  if (frame_graph)
    frame_graph->reset();
  else
    frame_graph.emplace("frame");
  RenderGraph& graph = *frame_graph;
  auto& board = graph.blackboard();
  frame::put_scene_targets(
      board, {.uniforms = graph.import_buffer("frame_uniforms", &*uniforms, gpu::Access::UniformRead),
              .environment = graph.import_texture("environment", &*environment, gpu::Access::ShaderRead)});
  if (key_light)
    shadow->add(graph, shadow_casters, frame_uniforms.light_view_projection);
  else
    frame::put_scene_targets(board, {.shadow_map = graph.import_texture("no_shadow", &*no_shadow, gpu::Access::ShaderRead)});
  if (auto ok = forward->add(graph, items); !ok) return std::unexpected(ok.error());
  for (const std::string& type : feature_order()) {
    const auto& feature = features.at(type);
    const auto w = std::uint32_t(frame_uniforms.viewport.x), h = std::uint32_t(frame_uniforms.viewport.y);
    if (auto ok = feature->add_passes(graph, feature_frame(scene, type, options, w, h)); !ok)
      return with_context(weft::format("feature '{}'", feature->name()), ok.error());
  }
  if (auto ok = background->add(graph); !ok) return std::unexpected(ok.error());
  if (options.read_hdr) {
    auto targets = frame::scene_targets(board);
    if (!targets) return std::unexpected(targets.error());
    const TextureHandle color = targets->color;
    struct HdrCopy {
      TextureHandle color;
      BufferHandle readback;
    };
    const BufferHandle target = graph.import_buffer("hdr_readback", &*hdr_readback, gpu::Access::Undefined);
    auto& copy = graph.add_pass<HdrCopy>(
        "hdr_readback",
        [&](PassBuilder& b, HdrCopy& d) {
          d.color = b.read(color, TextureUse::CopySrc);
          d.readback = b.write(target, BufferUse::CopyDst);
        },
        [](const PassResources& res, const HdrCopy& d, PassContext& ctx) {
          ctx.encoder().copy_texture_to_buffer(res.texture(d.color), res.buffer(d.readback), 0);
        });
    graph.mark_output(copy.readback, gpu::Access::HostRead);
  }
  auto out = tonemap->add(graph, graph.import_texture("output", &*output, gpu::Access::Undefined),
                          {.exposure = options.exposure,
                           .tone_operator = options.aces ? passes::ToneOperator::Aces : passes::ToneOperator::Clamp});
  if (!out) return std::unexpected(out.error());
  graph.mark_output(*out, gpu::Access::CopySrc);
  return std::pair{&graph, *out};
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

Result<GraphReport> Renderer::describe(const scene::Scene& scene, const RenderOptions& options) {
  auto size = frame_size(scene, options);
  if (!size) return std::unexpected(size.error());
  const bool key = has_key_light(scene);
  auto& s = *state_;
  if (auto ok = s.ensure_passes(key, options.quality); !ok) return std::unexpected(ok.error());
  if (auto ok = s.upload_scene(scene); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare(scene, options, size->first, size->second); !ok) return std::unexpected(ok.error());
  auto built = s.build_graph(scene, options, key);
  if (!built) return std::unexpected(built.error());
  auto compiled = built->first->compile({.output_extent = {size->first, size->second, 1}, .device = s.device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  GraphReport report{compiled->to_dot(), compiled->dump(), {}, {}};
  for (auto index : compiled->order()) report.passes.emplace_back(compiled->passes()[index].name);
  for (const auto& p : compiled->passes())
    if (p.culled) report.culled_passes.emplace_back(p.name);
  return report;
}

Result<Frame> Renderer::render(const scene::Scene& scene, const RenderOptions& options) {
  auto size = frame_size(scene, options);
  if (!size) return std::unexpected(size.error());
  const auto [w, h] = *size;
  const bool key = has_key_light(scene);
  auto& s = *state_;
  if (auto ok = s.ensure_passes(key, options.quality); !ok) return std::unexpected(ok.error());
  if (auto ok = s.upload_scene(scene); !ok) return std::unexpected(ok.error());
  if (auto ok = s.prepare(scene, options, w, h); !ok) return std::unexpected(ok.error());
  auto built = s.build_graph(scene, options, key);
  if (!built) return std::unexpected(built.error());
  auto compiled = built->first->compile({.output_extent = {w, h, 1}, .device = s.device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  ++(compiled->plan_reused() ? s.stats.graph_plans_reused : s.stats.graph_plans);
  auto stats = compiled->execute(*s.device, {.timestamps = options.timestamps, .serial_passes = options.serial_passes});
  if (!stats) return std::unexpected(stats.error());
  auto pixels = s.device->queue().read_texture(*s.output);
  if (!pixels) return std::unexpected(pixels.error());
  Frame frame;
  frame.image = image::Image8::filled(w, h, 4);
  std::memcpy(frame.image.pixels.data(), pixels->data(), frame.image.pixels.size());
  if (options.read_hdr) {
    auto bytes = s.device->queue().read_buffer(*s.hdr_readback);
    if (!bytes) return std::unexpected(bytes.error());
    frame.hdr = image::Image::filled(w, h, 4);
    const auto* halves = reinterpret_cast<const std::uint16_t*>(bytes->data());
    for (std::size_t i = 0; i < frame.hdr.pixels.size(); ++i) frame.hdr.pixels[i] = glm::unpackHalf1x16(halves[i]);
  }
  frame.stats = std::move(*stats);
  for (auto index : compiled->order()) frame.passes.emplace_back(compiled->passes()[index].name);
  frame.warnings = s.warnings;
  return frame;
}

}  // namespace weft::renderer
