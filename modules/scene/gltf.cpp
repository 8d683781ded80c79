// glTF 2.0 into weft.scene: tinygltf parses (gltf_loader.cpp); this unit checks every index
// and byte range before it reads, and turns meshes, materials, the node hierarchy, cameras
// and KHR_lights_punctual into weft types. Skins, animations and morph targets are ignored
// (the static pose is drawn); orthographic cameras are skipped with a warning.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <variant>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include "gltf_loader.h"
#include <weft/text_input.h>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

constexpr float degrees_per_radian = 57.29577951308232f;

std::string trim(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  return text;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = trim(text.substr(start, end - start));
    if (!line.empty()) out.push_back(std::move(line));
    start = end + 1;
  }
  return out;
}

// "%20" -> " " (glTF URIs are percent-encoded).
std::string percent_decode(std::string_view uri) {
  std::string out;
  out.reserve(uri.size());
  const auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0) {
      out.push_back(static_cast<char>(hex(uri[i + 1]) * 16 + hex(uri[i + 2])));
      i += 2;
    } else {
      out.push_back(uri[i]);
    }
  }
  return out;
}

class Converter {
 public:
  Converter(const std::filesystem::path& path, const tinygltf::Model& model) : path_(path), model_(model) {
    out_.source = path;
    std::error_code ec;
    base_dir_ = std::filesystem::absolute(path, ec).parent_path();
  }

  Result<GltfScene> run(const std::string& tinygltf_warnings) {
    for (const std::string& line : split_lines(tinygltf_warnings)) warn(weft::format("tinygltf: {}", line));
    if (auto r = check_asset(); !r) return std::unexpected(r.error());
    if (auto r = check_extensions(); !r) return std::unexpected(r.error());
    if (auto r = check_buffer_views(); !r) return std::unexpected(r.error());
    if (auto r = convert_materials(); !r) return std::unexpected(r.error());
    if (auto r = convert_meshes(); !r) return std::unexpected(r.error());
    if (auto r = convert_nodes(); !r) return std::unexpected(r.error());
    if (out_.instances.empty()) return error(ErrorKind::InvalidArgument, "the scene draws no triangle meshes");
    return std::move(out_);
  }

 private:
  template <class... Args>
  std::unexpected<Error> error(ErrorKind kind, fmt::format_string<Args...> f, Args&&... args) const {
    return fail(kind, "glTF '{}': {}", path_.string(), fmt::vformat(f, fmt::make_format_args(args...)));
  }
  void warn(std::string message) {
    detail::warn(out_.warnings, weft::format("glTF '{}': {}", path_.string(), message));
  }

  // glTF 1.0 files parse as JSON too, but mean something else; "scene" must name a scene.
  Result<void> check_asset() const {
    const std::string& version = model_.asset.version;
    if (!version.starts_with("2.")) {
      return error(ErrorKind::Unsupported, "asset.version is '{}'; weft reads glTF 2.x", version);
    }
    if (!model_.asset.minVersion.empty() && !model_.asset.minVersion.starts_with("2.")) {
      return error(ErrorKind::Unsupported, "asset.minVersion is '{}'; weft reads glTF 2.x", model_.asset.minVersion);
    }
    if (model_.defaultScene >= 0 && std::size_t(model_.defaultScene) >= model_.scenes.size()) {
      return error(ErrorKind::Parse, "\"scene\" is {}, but there are {} scenes", model_.defaultScene, model_.scenes.size());
    }
    return {};
  }

  Result<void> check_extensions() const {
    static constexpr std::string_view understood[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength"};
    std::vector<std::string> missing;
    for (const std::string& ext : model_.extensionsRequired) {
      if (std::find(std::begin(understood), std::end(understood), ext) == std::end(understood)) missing.push_back(ext);
    }
    if (!missing.empty()) {
      return error(ErrorKind::Unsupported, "requires extensions weft does not read: {}", fmt::join(missing, ", "));
    }
    return {};
  }

  Result<void> check_buffer_views() const {
    for (std::size_t i = 0; i < model_.bufferViews.size(); ++i) {
      const tinygltf::BufferView& bv = model_.bufferViews[i];
      if (bv.buffer < 0 || std::size_t(bv.buffer) >= model_.buffers.size()) {
        return error(ErrorKind::Parse, "bufferView {} names buffer {}, but there are {} buffers", i, bv.buffer,
                     model_.buffers.size());
      }
      const std::size_t size = model_.buffers[std::size_t(bv.buffer)].data.size();
      if (bv.byteOffset > size || bv.byteLength > size - bv.byteOffset) {
        return error(ErrorKind::Parse, "bufferView {} (bytes {} to {}) lies outside buffer {} of {} bytes", i,
                     bv.byteOffset, bv.byteOffset + bv.byteLength, bv.buffer, size);
      }
    }
    return {};
  }

  // ---- accessors ----
  struct View {
    const unsigned char* data = nullptr;  // null: all zeros (an accessor without bufferView)
    std::size_t stride = 0;
    std::size_t count = 0;
    int component_type = 0;
    int components = 0;
    bool normalized = false;
  };

  Result<View> view(int index, std::string_view what, std::initializer_list<int> types,
                    std::initializer_list<int> component_types) const {
    if (index < 0 || std::size_t(index) >= model_.accessors.size()) {
      return error(ErrorKind::Parse, "{} uses accessor {}, but there are {} accessors", what, index,
                   model_.accessors.size());
    }
    const tinygltf::Accessor& acc = model_.accessors[std::size_t(index)];
    if (acc.sparse.isSparse) return error(ErrorKind::Unsupported, "{}: accessor {} is sparse", what, index);
    if (std::find(types.begin(), types.end(), acc.type) == types.end()) {
      return error(ErrorKind::Parse, "{}: accessor {} has the wrong type ({})", what, index, acc.type);
    }
    if (std::find(component_types.begin(), component_types.end(), acc.componentType) == component_types.end()) {
      return error(ErrorKind::Parse, "{}: accessor {} has an unsupported component type ({})", what, index,
                   acc.componentType);
    }
    View v;
    v.count = acc.count;
    v.component_type = acc.componentType;
    v.components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(acc.type));
    v.normalized = acc.normalized;
    const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(acc.componentType));
    const std::size_t element = std::size_t(component_size) * std::size_t(v.components);
    if (acc.bufferView < 0) {
      if (acc.count > (std::size_t{1} << 22)) return error(ErrorKind::Parse, "{}: accessor {} (no bufferView) is too large", what, index);
      return v;  // zeros, as the spec says
    }
    if (std::size_t(acc.bufferView) >= model_.bufferViews.size()) {
      return error(ErrorKind::Parse, "{}: accessor {} uses bufferView {}, but there are {}", what, index,
                   acc.bufferView, model_.bufferViews.size());
    }
    const tinygltf::BufferView& bv = model_.bufferViews[std::size_t(acc.bufferView)];
    v.stride = bv.byteStride == 0 ? element : bv.byteStride;
    if (v.stride < element || v.stride > 255) {
      return error(ErrorKind::Parse, "{}: accessor {} has a byte stride of {} for {}-byte elements", what, index,
                   v.stride, element);
    }
    if (v.count > 0) {
      if (acc.byteOffset > bv.byteLength || v.count > bv.byteLength ||
          acc.byteOffset + v.stride * (v.count - 1) + element > bv.byteLength) {
        return error(ErrorKind::Parse, "{}: accessor {} ({} elements from byte {}) reads past the end of bufferView {} ({} bytes)",
                     what, index, v.count, acc.byteOffset, acc.bufferView, bv.byteLength);
      }
    }
    v.data = model_.buffers[std::size_t(bv.buffer)].data.data() + bv.byteOffset + acc.byteOffset;
    return v;
  }

  static float component(const View& v, std::size_t element, int c) {
    if (v.data == nullptr) return 0.0f;
    const unsigned char* p = v.data + element * v.stride;
    switch (v.component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p + 4 * c, 4);
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        const float f = p[c];
        return v.normalized ? f / 255.0f : f;
      }
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const float f = static_cast<std::int8_t>(p[c]);
        return v.normalized ? std::max(f / 127.0f, -1.0f) : f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t u;
        std::memcpy(&u, p + 2 * c, 2);
        return v.normalized ? float(u) / 65535.0f : float(u);
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t s;
        std::memcpy(&s, p + 2 * c, 2);
        return v.normalized ? std::max(float(s) / 32767.0f, -1.0f) : float(s);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t u;
        std::memcpy(&u, p + 4 * c, 4);
        return float(u);
      }
      default: return 0.0f;
    }
  }

  static std::uint32_t index_at(const View& v, std::size_t element) {
    if (v.data == nullptr) return 0;
    const unsigned char* p = v.data + element * v.stride;
    switch (v.component_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t u;
        std::memcpy(&u, p, 2);
        return u;
      }
      default: {
        std::uint32_t u;
        std::memcpy(&u, p, 4);
        return u;
      }
    }
  }

  template <class Vec>
  Result<std::vector<Vec>> read_vectors(int index, std::string_view what, int type,
                                        std::initializer_list<int> component_types, std::size_t expected_count) const {
    auto v = view(index, what, {type}, component_types);
    if (!v) return std::unexpected(v.error());
    if (expected_count != ~std::size_t{0} && v->count != expected_count) {
      return error(ErrorKind::Parse, "{}: accessor {} has {} elements, POSITION has {}", what, index, v->count,
                   expected_count);
    }
    std::vector<Vec> out(v->count);
    for (std::size_t i = 0; i < v->count; ++i) {
      for (int c = 0; c < Vec::length(); ++c) out[i][c] = component(*v, i, c);
    }
    return out;
  }

  // ---- materials ----
  Result<Texture> texture(int index, std::string_view material, std::string_view slot) {
    Texture t;
    if (index < 0) return t;
    if (std::size_t(index) >= model_.textures.size()) {
      return error(ErrorKind::Parse, "material '{}' {} uses texture {}, but there are {} textures", material, slot,
                   index, model_.textures.size());
    }
    const int source = model_.textures[std::size_t(index)].source;
    if (source < 0) {
      warn(weft::format("material '{}' {}: texture {} has no image; using the factors only", material, slot, index));
      return t;
    }
    if (std::size_t(source) >= model_.images.size()) {
      return error(ErrorKind::Parse, "texture {} uses image {}, but there are {} images", index, source,
                   model_.images.size());
    }
    const tinygltf::Image& image = model_.images[std::size_t(source)];
    if (!image.image.empty()) {  // embedded: a data URI or a GLB buffer view
      t.encoded = image.image;
      t.mime_type = image.mimeType;
      t.label = weft::format("glTF '{}' image {}{}", path_.string(), source, image.name.empty() ? "" : " '" + image.name + "'");
      return t;
    }
    if (image.uri.empty()) {
      warn(weft::format("material '{}' {}: image {} has no data; using the factors only", material, slot, source));
      return t;
    }
    const auto inside = gltf_detail::resolve_inside(base_dir_, percent_decode(image.uri));
    if (!inside) {
      return error(ErrorKind::InvalidArgument, "material '{}' {}: image uri '{}' leads outside the glTF file's folder",
                   material, slot, image.uri);
    }
    const std::filesystem::path& file = *inside;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      warn(weft::format("material '{}' {}: texture file '{}' not found; using the factors only", material, slot,
                        file.string()));
      return t;
    }
    t.path = file;
    const std::string ext = detail::lowercase_extension(file);
    t.mime_type = ext == ".png" ? "image/png" : (ext == ".jpg" || ext == ".jpeg") ? "image/jpeg" : image.mimeType;
    return t;
  }

  // A material's texture slot: the image, the UV set it reads and its sampler.
  template <class Info>
  Result<Texture> material_texture(const Info& info, std::string_view material, std::string_view slot) {
    auto t = texture(info.index, material, slot);
    if (!t || t->empty()) return t;
    if (info.texCoord < 0) {
      return error(ErrorKind::Parse, "material '{}' {}: texCoord {} is negative", material, slot, info.texCoord);
    }
    if (info.texCoord > 1) {
      warn(weft::format("material '{}' {}: texCoord {} (weft reads TEXCOORD_0 and TEXCOORD_1); reading TEXCOORD_0",
                        material, slot, info.texCoord));
    } else {
      t->texcoord = static_cast<std::uint32_t>(info.texCoord);
    }
    auto sampler = texture_sampler(info.index, material, slot);
    if (!sampler) return std::unexpected(sampler.error());
    t->sampler = *sampler;
    return t;
  }

  // glTF's sampler of a texture (none: repeat, linear). Mipmap filters read as their base
  // filter: weft samples level 0.
  Result<TextureSampler> texture_sampler(int texture_index, std::string_view material, std::string_view slot) const {
    TextureSampler out;
    const int index = model_.textures[std::size_t(texture_index)].sampler;
    if (index < 0) return out;
    if (std::size_t(index) >= model_.samplers.size()) {
      return error(ErrorKind::Parse, "material '{}' {}: texture {} uses sampler {}, but there are {} samplers", material,
                   slot, texture_index, index, model_.samplers.size());
    }
    const tinygltf::Sampler& s = model_.samplers[std::size_t(index)];
    const auto wrap = [&](int mode, std::string_view axis) -> Result<TextureWrap> {
      switch (mode) {
        case -1:
        case TINYGLTF_TEXTURE_WRAP_REPEAT: return TextureWrap::Repeat;
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return TextureWrap::ClampToEdge;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return TextureWrap::MirroredRepeat;
        default: return error(ErrorKind::Parse, "sampler {} has an unknown {} {}", index, axis, mode);
      }
    };
    const auto filter = [&](int mode, std::string_view which) -> Result<TextureFilter> {
      switch (mode) {
        case -1:
        case TINYGLTF_TEXTURE_FILTER_LINEAR:
        case TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_NEAREST:
        case TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR: return TextureFilter::Linear;
        case TINYGLTF_TEXTURE_FILTER_NEAREST:
        case TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_NEAREST:
        case TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_LINEAR: return TextureFilter::Nearest;
        default: return error(ErrorKind::Parse, "sampler {} has an unknown {} {}", index, which, mode);
      }
    };
    auto u = wrap(s.wrapS, "wrapS");
    auto v = wrap(s.wrapT, "wrapT");
    auto mag = filter(s.magFilter, "magFilter");
    auto min = filter(s.minFilter, "minFilter");
    for (const Error* e : {u ? nullptr : &u.error(), v ? nullptr : &v.error(), mag ? nullptr : &mag.error(),
                           min ? nullptr : &min.error()}) {
      if (e) return std::unexpected(*e);
    }
    return TextureSampler{*u, *v, *mag, *min};
  }

  Result<void> convert_materials() {
    for (std::size_t i = 0; i < model_.materials.size(); ++i) {
      const tinygltf::Material& src = model_.materials[i];
      Material m;
      m.name = src.name.empty() ? weft::format("material {}", i) : src.name;
      StandardMaterial& s = m.standard;
      const auto& pbr = src.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() == 4) {
        s.base_color = vec3(float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]), float(pbr.baseColorFactor[2]));
        s.alpha = float(pbr.baseColorFactor[3]);
      } else {
        s.base_color = vec3(1.0f);
      }
      s.metallic = std::clamp(float(pbr.metallicFactor), 0.0f, 1.0f);
      s.roughness = std::clamp(float(pbr.roughnessFactor), 0.0f, 1.0f);
      if (src.emissiveFactor.size() == 3) {
        s.emissive = vec3(float(src.emissiveFactor[0]), float(src.emissiveFactor[1]), float(src.emissiveFactor[2]));
      }
      s.normal_scale = float(src.normalTexture.scale);
      s.occlusion_strength = std::clamp(float(src.occlusionTexture.strength), 0.0f, 1.0f);
      if (const auto it = src.extensions.find("KHR_materials_emissive_strength"); it != src.extensions.end() &&
          it->second.Has("emissiveStrength") && it->second.Get("emissiveStrength").IsNumber()) {
        s.emissive *= float(it->second.Get("emissiveStrength").GetNumberAsDouble());
      }
      auto base = material_texture(pbr.baseColorTexture, m.name, "baseColorTexture");
      auto mr = material_texture(pbr.metallicRoughnessTexture, m.name, "metallicRoughnessTexture");
      auto normal = material_texture(src.normalTexture, m.name, "normalTexture");
      auto occlusion = material_texture(src.occlusionTexture, m.name, "occlusionTexture");
      auto emissive = material_texture(src.emissiveTexture, m.name, "emissiveTexture");
      for (auto* r : {&base, &mr, &normal, &occlusion, &emissive}) {
        if (!*r) return std::unexpected(r->error());
      }
      s.base_color_texture = std::move(*base);
      s.metallic_roughness_texture = std::move(*mr);
      s.normal_texture = std::move(*normal);
      s.occlusion_texture = std::move(*occlusion);
      s.emissive_texture = std::move(*emissive);
      const bool finite = std::isfinite(s.base_color.x + s.base_color.y + s.base_color.z + s.alpha + s.metallic +
                                        s.roughness + s.emissive.x + s.emissive.y + s.emissive.z + s.normal_scale +
                                        s.occlusion_strength);
      if (!finite) return error(ErrorKind::Parse, "material '{}' has a non-finite factor", m.name);
      out_.materials.push_back(std::move(m));
    }
    return {};
  }

  std::uint32_t default_material() {
    if (!default_material_) {
      Material m;
      m.name = "default";
      default_material_ = static_cast<std::uint32_t>(out_.materials.size());
      out_.materials.push_back(std::move(m));
    }
    return *default_material_;
  }

  // ---- meshes ----
  struct PrimitiveRef {
    std::uint32_t mesh;
    std::uint32_t material;
  };

  Result<void> convert_meshes() {
    primitives_.resize(model_.meshes.size());
    for (std::size_t mi = 0; mi < model_.meshes.size(); ++mi) {
      const tinygltf::Mesh& gm = model_.meshes[mi];
      const std::string mesh_name = gm.name.empty() ? weft::format("mesh {}", mi) : gm.name;
      for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
        const tinygltf::Primitive& prim = gm.primitives[pi];
        const std::string name = gm.primitives.size() == 1 ? mesh_name : weft::format("{}/{}", mesh_name, pi);
        const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
            mode == TINYGLTF_MODE_LINE_STRIP) {
          warn(weft::format("mesh '{}' draws points or lines (mode {}); skipped", name, mode));
          continue;
        }
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
          return error(ErrorKind::Parse, "mesh '{}' has an unknown primitive mode {}", name, mode);
        }
        auto mesh = convert_primitive(prim, name, mode);
        if (!mesh) return std::unexpected(mesh.error());
        std::uint32_t material = 0;
        if (prim.material < 0) {
          material = default_material();
        } else if (std::size_t(prim.material) < model_.materials.size()) {
          material = static_cast<std::uint32_t>(prim.material);
        } else {
          return error(ErrorKind::Parse, "mesh '{}' uses material {}, but there are {} materials", name, prim.material,
                       model_.materials.size());
        }
        primitives_[mi].push_back({static_cast<std::uint32_t>(out_.meshes.size()), material});
        out_.meshes.push_back(std::move(*mesh));
      }
    }
    return {};
  }

  Result<Mesh> convert_primitive(const tinygltf::Primitive& prim, const std::string& name, int mode) const {
    const auto attribute = [&](const char* key) -> int {
      const auto it = prim.attributes.find(key);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    Mesh mesh;
    mesh.name = name;
    const std::string what = weft::format("mesh '{}'", name);
    const int position = attribute("POSITION");
    if (position < 0) return error(ErrorKind::Parse, "{} has no POSITION attribute", what);
    auto positions = read_vectors<vec3>(position, what + " POSITION", TINYGLTF_TYPE_VEC3,
                                        {TINYGLTF_COMPONENT_TYPE_FLOAT}, ~std::size_t{0});
    if (!positions) return std::unexpected(positions.error());
    mesh.positions = std::move(*positions);
    const std::size_t n = mesh.positions.size();
    if (const int a = attribute("NORMAL"); a >= 0) {
      auto normals = read_vectors<vec3>(a, what + " NORMAL", TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT}, n);
      if (!normals) return std::unexpected(normals.error());
      mesh.normals = std::move(*normals);
    }
    for (auto [set, out] : {std::pair{"TEXCOORD_0", &mesh.uvs}, std::pair{"TEXCOORD_1", &mesh.uvs1}}) {
      const int a = attribute(set);
      if (a < 0) continue;
      auto uvs = read_vectors<vec2>(a, what + " " + set, TINYGLTF_TYPE_VEC2,
                                    {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                    n);
      if (!uvs) return std::unexpected(uvs.error());
      *out = std::move(*uvs);
    }
    if (const int a = attribute("TANGENT"); a >= 0 && !mesh.normals.empty()) {
      auto tangents = read_vectors<vec4>(a, what + " TANGENT", TINYGLTF_TYPE_VEC4, {TINYGLTF_COMPONENT_TYPE_FLOAT}, n);
      if (!tangents) return std::unexpected(tangents.error());
      mesh.tangents = std::move(*tangents);
    }
    std::vector<std::uint32_t> order;
    if (prim.indices >= 0) {
      auto v = view(prim.indices, what + " indices", {TINYGLTF_TYPE_SCALAR},
                    {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
      if (!v) return std::unexpected(v.error());
      order.resize(v->count);
      for (std::size_t i = 0; i < v->count; ++i) {
        order[i] = index_at(*v, i);
        if (order[i] >= n) {
          return error(ErrorKind::Parse, "{}: index {} is {}, but there are {} vertices", what, i, order[i], n);
        }
      }
    } else {
      order.resize(n);
      for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
    }
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      order.resize(order.size() / 3 * 3);
      mesh.indices = std::move(order);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (std::size_t i = 2; i < order.size(); ++i) {
        if (i % 2 == 0) mesh.indices.insert(mesh.indices.end(), {order[i - 2], order[i - 1], order[i]});
        else mesh.indices.insert(mesh.indices.end(), {order[i - 1], order[i - 2], order[i]});
      }
    } else {
      for (std::size_t i = 2; i < order.size(); ++i) mesh.indices.insert(mesh.indices.end(), {order[0], order[i - 1], order[i]});
    }
    return mesh;
  }

  // ---- nodes ----
  Result<mat4> local_matrix(const tinygltf::Node& node, std::size_t index) const {
    if (!node.matrix.empty()) {
      if (node.matrix.size() != 16) return error(ErrorKind::Parse, "node {} has a matrix of {} numbers", index, node.matrix.size());
      mat4 m;
      for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) m[c][r] = float(node.matrix[std::size_t(c * 4 + r)]);  // column-major, as GLM
      }
      return m;
    }
    vec3 t(0.0f), s(1.0f);
    quat q(1.0f, 0.0f, 0.0f, 0.0f);
    if (!node.translation.empty()) {
      if (node.translation.size() != 3) return error(ErrorKind::Parse, "node {} has a translation of {} numbers", index, node.translation.size());
      t = vec3(float(node.translation[0]), float(node.translation[1]), float(node.translation[2]));
    }
    if (!node.rotation.empty()) {
      if (node.rotation.size() != 4) return error(ErrorKind::Parse, "node {} has a rotation of {} numbers", index, node.rotation.size());
      q = quat(float(node.rotation[3]), float(node.rotation[0]), float(node.rotation[1]), float(node.rotation[2]));
      const float len = glm::length(q);
      q = len > 0.0f ? q / len : quat(1.0f, 0.0f, 0.0f, 0.0f);
    }
    if (!node.scale.empty()) {
      if (node.scale.size() != 3) return error(ErrorKind::Parse, "node {} has a scale of {} numbers", index, node.scale.size());
      s = vec3(float(node.scale[0]), float(node.scale[1]), float(node.scale[2]));
    }
    return Transform{t, q, s}.matrix();
  }

  Result<void> convert_nodes() {
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
      const std::size_t scene =
          model_.defaultScene >= 0 && std::size_t(model_.defaultScene) < model_.scenes.size() ? std::size_t(model_.defaultScene) : 0;
      roots = model_.scenes[scene].nodes;
    } else {
      std::vector<char> is_child(model_.nodes.size(), 0);
      for (const tinygltf::Node& node : model_.nodes) {
        for (int c : node.children) {
          if (c >= 0 && std::size_t(c) < model_.nodes.size()) is_child[std::size_t(c)] = 1;
        }
      }
      for (std::size_t i = 0; i < model_.nodes.size(); ++i) {
        if (!is_child[i]) roots.push_back(static_cast<int>(i));
      }
    }
    on_path_.assign(model_.nodes.size(), 0);
    for (int root : roots) {
      if (auto r = visit_tree(root); !r) return r;
    }
    return {};
  }

  // Depth first, with the path from the root kept in a vector rather than on the call
  // stack: a valid file may chain tens of thousands of nodes.
  Result<void> visit_tree(int root) {
    struct OnPath {
      int index;
      mat4 world;
      std::size_t next_child;
    };
    std::vector<OnPath> path;
    auto world = visit(root, mat4(1.0f), -1);
    if (!world) return std::unexpected(world.error());
    path.push_back({root, *world, 0});
    while (!path.empty()) {
      OnPath& top = path.back();
      const std::vector<int>& children = model_.nodes[std::size_t(top.index)].children;
      if (top.next_child == children.size()) {
        on_path_[std::size_t(top.index)] = 0;
        path.pop_back();
        continue;
      }
      const int child = children[top.next_child++];
      const int parent = top.index;
      auto child_world = visit(child, top.world, parent);
      if (!child_world) return std::unexpected(child_world.error());
      path.push_back({child, *child_world, 0});
    }
    return {};
  }

  // One node: checks it, adds its instances, camera and light, marks it on the path and
  // returns its world matrix (visit_tree walks its children).
  Result<mat4> visit(int index, const mat4& parent, int parent_index) {
    if (index < 0 || std::size_t(index) >= model_.nodes.size()) {
      if (parent_index < 0) return error(ErrorKind::Parse, "the scene names node {}, but there are {} nodes", index, model_.nodes.size());
      return error(ErrorKind::Parse, "node {} has child {}, but there are {} nodes", parent_index, index, model_.nodes.size());
    }
    const auto i = std::size_t(index);
    if (on_path_[i]) return error(ErrorKind::Parse, "node {} is its own ancestor (the hierarchy has a cycle)", index);
    if (++visits_ > 1'000'000) return error(ErrorKind::Parse, "the node hierarchy expands to more than a million nodes");
    const tinygltf::Node& node = model_.nodes[i];
    auto local = local_matrix(node, i);
    if (!local) return std::unexpected(local.error());
    const mat4 world = parent * *local;
    const std::string node_name = node.name.empty() ? weft::format("node {}", index) : node.name;

    if (node.mesh >= 0) {
      if (std::size_t(node.mesh) >= model_.meshes.size()) {
        return error(ErrorKind::Parse, "node {} uses mesh {}, but there are {} meshes", index, node.mesh, model_.meshes.size());
      }
      for (const PrimitiveRef& p : primitives_[std::size_t(node.mesh)]) {
        out_.instances.push_back(Object{node_name, p.mesh, p.material, world});
      }
    }
    const vec3 origin = vec3(world * vec4(0.0f, 0.0f, 0.0f, 1.0f));
    const vec3 forward = safe_normalize(mat3(world) * vec3(0.0f, 0.0f, -1.0f), vec3(0.0f, 0.0f, -1.0f));
    if (node.camera >= 0) {
      if (std::size_t(node.camera) >= model_.cameras.size()) {
        return error(ErrorKind::Parse, "node {} uses camera {}, but there are {} cameras", index, node.camera, model_.cameras.size());
      }
      const tinygltf::Camera& cam = model_.cameras[std::size_t(node.camera)];
      if (cam.type != "perspective") {
        warn(weft::format("camera {} of node '{}' is {}; only perspective cameras are read", node.camera, node_name, cam.type));
      } else {
        Camera c;
        c.position = origin;
        c.target = origin + forward;
        c.up = safe_normalize(mat3(world) * vec3(0.0f, 1.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f));
        c.fov_y_degrees = float(cam.perspective.yfov) * degrees_per_radian;
        c.near = float(cam.perspective.znear);
        c.far = cam.perspective.zfar > cam.perspective.znear ? float(cam.perspective.zfar) : c.near * 10000.0f;
        if (auto ok = validate(c); !ok) {
          warn(weft::format("camera {} of node '{}' skipped: {}", node.camera, node_name, ok.error().message));
        } else {
          out_.cameras.push_back(c);
        }
      }
    }
    if (const auto ext = node.extensions.find("KHR_lights_punctual"); ext != node.extensions.end()) {
      if (auto r = add_light(ext->second, node_name, origin, forward); !r) return std::unexpected(r.error());
    }
    on_path_[i] = 1;
    return world;
  }

  static vec3 safe_normalize(const vec3& v, const vec3& fallback) {
    const float len = glm::length(v);
    return len > 0.0f && std::isfinite(len) ? v / len : fallback;
  }

  Result<void> add_light(const tinygltf::Value& ext, const std::string& node_name, const vec3& origin, const vec3& forward) {
    if (!ext.IsObject() || !ext.Has("light") || !(ext.Get("light").IsInt() || ext.Get("light").IsNumber())) {
      warn(weft::format("node '{}' has a KHR_lights_punctual entry without a light index; ignored", node_name));
      return {};
    }
    const int light = ext.Get("light").GetNumberAsInt();
    if (light < 0 || std::size_t(light) >= model_.lights.size()) {
      return error(ErrorKind::Parse, "node '{}' uses light {}, but there are {} lights", node_name, light, model_.lights.size());
    }
    const tinygltf::Light& src = model_.lights[std::size_t(light)];
    vec3 color(1.0f);
    if (src.color.size() == 3) color = vec3(float(src.color[0]), float(src.color[1]), float(src.color[2]));
    const float intensity = float(src.intensity);
    const float range = float(src.range);
    const std::string name = src.name.empty() ? node_name : src.name;
    if (!std::isfinite(color.x + color.y + color.z + intensity + range) || intensity < 0.0f) {
      return error(ErrorKind::Parse, "light '{}' has a non-finite or negative color, intensity or range", name);
    }
    if (double(intensity) > max_light_intensity || double(std::max({color.x, color.y, color.z})) > max_light_color) {
      return error(ErrorKind::Parse, "light '{}' has intensity {} and color ({}, {}, {}); weft draws up to intensity {} and color {}",
                   name, intensity, color.x, color.y, color.z, max_light_intensity, max_light_color);
    }
    if (src.type == "directional") {
      out_.lights.emplace_back(DirectionalLight{name, forward, color, intensity});
    } else if (src.type == "point") {
      out_.lights.emplace_back(PointLight{name, origin, color, intensity, std::max(range, 0.0f)});
    } else if (src.type == "spot") {
      const float inner = float(src.spot.innerConeAngle) * degrees_per_radian;
      const float outer = float(src.spot.outerConeAngle) * degrees_per_radian;
      if (!(inner >= 0.0f && inner < outer && outer <= 90.0f)) {
        return error(ErrorKind::Parse, "spot light '{}' has cone angles {} and {} degrees (need 0 <= inner < outer <= 90)", name,
                     inner, outer);
      }
      out_.lights.emplace_back(SpotLight{name, origin, forward, color, intensity, std::max(range, 0.0f), inner, outer});
    } else {
      warn(weft::format("light '{}' has unknown type '{}'; ignored", name, src.type));
    }
    return {};
  }

  std::filesystem::path path_;
  std::filesystem::path base_dir_;
  const tinygltf::Model& model_;
  GltfScene out_;
  std::optional<std::uint32_t> default_material_;
  std::vector<std::vector<PrimitiveRef>> primitives_;
  std::vector<char> on_path_;
  std::size_t visits_ = 0;
};

// The JSON of a .gltf, or the JSON chunk of a .glb, checked before tinygltf reads it:
// tinygltf turns JSON into its values recursively (a file nested 20,000 deep overflows the
// stack), and glTF 2.0 forbids repeated keys. No real asset comes near this depth.
Result<void> check_json(const std::vector<unsigned char>& bytes) {
  constexpr std::size_t max_depth = 512;
  std::string_view json(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0) {
    std::uint32_t chunk_length = 0;
    if (bytes.size() < 20) return fail(ErrorKind::Parse, "the GLB header is cut short ({} bytes)", bytes.size());
    std::memcpy(&chunk_length, bytes.data() + 12, 4);
    if (chunk_length > bytes.size() - 20) {
      return fail(ErrorKind::Parse, "the GLB JSON chunk claims {} bytes, but {} follow", chunk_length, bytes.size() - 20);
    }
    json = json.substr(20, chunk_length);
  }
  return detail::check_json_structure(json, max_depth);
}

}  // namespace

namespace detail {

Result<GltfScene> read_gltf(const std::filesystem::path& path) {
  try {
    if (auto why = weft::binary_text_input(path, "glTF file", "glTF")) return fail(ErrorKind::Parse, "{}", *why);
    auto bytes = weft::read_input_file(path, "glTF file");
    if (!bytes) return std::unexpected(bytes.error());
    if (bytes->empty()) return fail(ErrorKind::Parse, "glTF '{}': the file is empty", path.string());
    if (auto ok = check_json(*bytes); !ok) return fail(ErrorKind::Parse, "glTF '{}': {}", path.string(), ok.error().message);
    std::error_code ec;
    const std::filesystem::path base_dir = std::filesystem::absolute(path, ec).parent_path();
    if (ec) return fail(ErrorKind::Io, "glTF '{}': {}", path.string(), ec.message());
    tinygltf::Model model;
    std::string err, warning;
    if (!gltf_detail::parse_model(*bytes, base_dir.string(), model, err, warning)) {
      const auto lines = split_lines(err);
      return fail(ErrorKind::Parse, "glTF '{}': {}", path.string(),
                  lines.empty() ? std::string("tinygltf could not parse it") : fmt::format("{}", fmt::join(lines, "; ")));
    }
    return Converter(path, model).run(warning);
  } catch (const std::bad_alloc&) {
    return fail(ErrorKind::Parse, "glTF '{}': out of memory while reading (a corrupt count?)", path.string());
  } catch (const std::exception& e) {
    return fail(ErrorKind::Parse, "glTF '{}': {}", path.string(), e.what());
  } catch (...) {
    return fail(ErrorKind::Internal, "glTF '{}': unknown exception", path.string());
  }
}

}  // namespace detail

Result<GltfScene> load_gltf(const std::filesystem::path& path, const LoadOptions& options) {
  auto scene = detail::read_gltf(path);
  if (!scene) return scene;
  try {
    for (Mesh& mesh : scene->meshes) {
      if (auto ok = detail::prepare_mesh(mesh, options, weft::format("glTF '{}' mesh '{}'", path.string(), mesh.name)); !ok) {
        return std::unexpected(ok.error());
      }
      for (const std::string& w : mesh.warnings) scene->warnings.push_back(w);
    }
  } catch (const std::exception& e) {
    return fail(ErrorKind::Internal, "glTF '{}': {}", path.string(), e.what());
  }
  return scene;
}

}  // namespace weft::scene
