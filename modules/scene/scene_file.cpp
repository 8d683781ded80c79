// The JSON scene file (docs/scene-format.md): parsed with nlohmann::json, read field by
// field with JsonReader so that every problem of a file is reported at once, each at its
// JSON path; names are resolved to indices and paths against the file's folder.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <weft/text_input.h>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

constexpr Range non_negative{.min = 0.0};
constexpr Range positive{.min = 0.0, .min_exclusive = true};
constexpr Range unit{.min = 0.0, .max = 1.0};
constexpr Range finite{};
constexpr Range count_range(double lo) { return Range{.min = lo, .max = double(max_primitive_count)}; }

// A unit direction, or an error when the array is all zeros.
vec3 direction(JsonReader& r, std::string_view key, vec3 fallback) {
  const vec3 d = r.vec3_of(key, fallback, finite);
  const float len = glm::length(d);
  if (!(len > 0.0f) || !std::isfinite(len)) {
    r.error_at(key, "a direction must not be zero");
    return fallback;
  }
  return d / len;
}

Output read_output(JsonReader& r) {
  Output out;
  out.width = static_cast<std::uint32_t>(r.integer("width", out.width, {.min = 1, .max = max_output_side}));
  out.height = static_cast<std::uint32_t>(r.integer("height", out.height, {.min = 1, .max = max_output_side}));
  r.finish();
  return out;
}

Camera read_camera(JsonReader& r) {
  Camera c;
  const std::size_t errors_before = r.errors().size();
  c.position = r.vec3_of("position", c.position, finite);
  c.target = r.vec3_of("target", c.target, finite);
  c.up = r.vec3_of("up", c.up, finite);
  c.fov_y_degrees = float(r.number("fov", c.fov_y_degrees, {.min = min_fov_degrees, .max = max_fov_degrees}));
  c.near = float(r.number("near", c.near, positive));
  c.far = float(r.number("far", c.far, positive));
  r.finish();
  if (r.errors().size() == errors_before) {
    if (auto ok = validate(c); !ok) r.error(ok.error().message);
  }
  return c;
}

EnvironmentSource read_environment(JsonReader& r) {
  EnvironmentSource env;
  if (r.has("hdr") && r.has("color")) r.error("give either \"hdr\" or \"color\", not both");
  env.hdr = r.path("hdr");
  if (!env.hdr.empty()) {
    const std::string ext = detail::lowercase_extension(env.hdr);
    if (ext != ".hdr" && ext != ".exr") r.error_at("hdr", fmt::format("'{}' is not a .hdr or .exr file", env.hdr.string()));
  }
  env.color = r.vec3_of("color", env.color, non_negative);
  env.intensity = float(r.number("intensity", env.intensity, non_negative));
  env.rotation_degrees = float(r.number("rotation", env.rotation_degrees, finite));
  r.finish();
  return env;
}

std::optional<Light> read_light(JsonReader& r, std::size_t index) {
  if (!r.is_object()) {
    r.error(fmt::format("expected an object, got {}", json_type_name(r.json())));
    return std::nullopt;
  }
  r.require("type");
  const std::string type = r.string("type", "", {"directional", "point", "spot"});
  const std::string name = r.string("name", fmt::format("light {}", index));
  const vec3 color = r.vec3_of("color", vec3(1.0f), {.min = 0.0, .max = max_light_color});
  const float intensity = float(r.number("intensity", 1.0, {.min = 0.0, .max = max_light_intensity}));
  std::optional<Light> light;
  if (type == "directional") {
    light = DirectionalLight{name, direction(r, "direction", vec3(0.0f, -1.0f, 0.0f)), color, intensity};
  } else if (type == "point") {
    light = PointLight{name, r.vec3_of("position", vec3(0.0f), finite), color, intensity,
                       float(r.number("range", 0.0, non_negative))};
  } else if (type == "spot") {
    SpotLight s{name, r.vec3_of("position", vec3(0.0f), finite), direction(r, "direction", vec3(0.0f, -1.0f, 0.0f)),
                color, intensity, float(r.number("range", 0.0, non_negative))};
    s.inner_cone_degrees = float(r.number("inner_cone", 0.0, {.min = 0, .max = 90, .max_exclusive = true}));
    s.outer_cone_degrees = float(r.number("outer_cone", 45.0, {.min = 0, .max = 90, .min_exclusive = true}));
    if (!(s.inner_cone_degrees < s.outer_cone_degrees)) {
      r.error(fmt::format("inner_cone ({}) must be smaller than outer_cone ({})", s.inner_cone_degrees, s.outer_cone_degrees));
    }
    light = s;
  }
  r.finish();
  return light;
}

MeshSource read_mesh_source(JsonReader& r, const std::string& name) {
  MeshSource src;
  src.name = name;
  if (!r.is_object()) {
    r.error(fmt::format("expected an object, got {}", json_type_name(r.json())));
    return src;
  }
  const bool has_path = r.has("path"), has_primitive = r.has("primitive");
  if (has_path && has_primitive) r.error("give either \"path\" or \"primitive\", not both");
  if (!has_path && !has_primitive) r.error("a mesh needs a \"path\" or a \"primitive\"");
  if (has_path) {
    src.path = r.path("path");
    if (!src.path.empty()) {
      const std::string ext = detail::lowercase_extension(src.path);
      static constexpr std::string_view formats[] = {".obj", ".ply", ".off", ".stl", ".gltf", ".glb"};
      if (std::find(std::begin(formats), std::end(formats), ext) == std::end(formats)) {
        r.error_at("path", fmt::format("unsupported mesh format '{}' (weft reads .obj .ply .off .stl .gltf .glb)", ext));
      }
    }
    src.options.recompute_normals = r.boolean("recompute_normals", false);
    src.options.normalize_to_unit_box = r.boolean("normalize_to_unit_box", false);
  } else if (has_primitive) {
    const std::string kind = r.string("primitive", "", {"sphere", "plane", "torus", "cube"});
    if (kind == "sphere") {
      src.primitive = PrimitiveKind::Sphere;
      src.radius = float(r.number("radius", src.radius, positive));
      src.segments = static_cast<std::uint32_t>(r.integer("segments", src.segments, count_range(3)));
    } else if (kind == "plane") {
      src.primitive = PrimitiveKind::Plane;
      src.size = float(r.number("size", src.size, positive));
      src.subdivisions = static_cast<std::uint32_t>(r.integer("subdivisions", src.subdivisions, count_range(1)));
    } else if (kind == "torus") {
      src.primitive = PrimitiveKind::Torus;
      src.major_radius = float(r.number("major_radius", src.major_radius, positive));
      src.minor_radius = float(r.number("minor_radius", src.minor_radius, positive));
      src.segments = static_cast<std::uint32_t>(r.integer("segments", src.segments, count_range(3)));
      src.sides = static_cast<std::uint32_t>(r.integer("sides", src.sides, count_range(3)));
      if (!(src.minor_radius < src.major_radius)) {
        r.error(fmt::format("minor_radius ({}) must be smaller than major_radius ({})", src.minor_radius, src.major_radius));
      }
    } else if (kind == "cube") {
      src.primitive = PrimitiveKind::Cube;
      src.size = float(r.number("size", src.size, positive));
    }
  }
  r.finish();
  return src;
}

Material read_material(JsonReader& r, const std::string& name) {
  Material m;
  m.name = name;
  m.json_path = r.json_path();
  m.base_dir = r.base_dir();
  if (!r.is_object()) {
    r.error(fmt::format("expected an object, got {}", json_type_name(r.json())));
    return m;
  }
  const std::string type = r.string("type", std::string(standard_material));
  if (auto resolved = resolve_material_type(type)) {
    m.type = std::move(*resolved);
  } else {
    // Its other fields are the unknown feature's: not reported as unknown standard fields.
    r.error_at("type", fmt::format("unknown material type '{}'; known: {}", type, known_material_types()));
    m.params = r.rest({"type"});
    return m;
  }
  if (m.type != standard_material) {
    // The feature's own pass reads and checks these (JsonReader on params at json_path).
    m.params = r.rest({"type"});
    return m;
  }
  StandardMaterial& s = m.standard;
  s.base_color = r.vec3_of("base_color", s.base_color, unit);
  s.alpha = float(r.number("alpha", s.alpha, unit));
  s.base_color_texture.path = r.path("base_color_texture");
  s.metallic = float(r.number("metallic", s.metallic, unit));
  s.roughness = float(r.number("roughness", s.roughness, unit));
  s.metallic_roughness_texture.path = r.path("metallic_roughness_texture");
  s.normal_texture.path = r.path("normal_texture");
  s.normal_scale = float(r.number("normal_scale", s.normal_scale, finite));
  s.occlusion_texture.path = r.path("occlusion_texture");
  s.occlusion_strength = float(r.number("occlusion_strength", s.occlusion_strength, unit));
  s.emissive = r.vec3_of("emissive", s.emissive, non_negative);
  s.emissive_texture.path = r.path("emissive_texture");
  r.finish();
  return m;
}

Transform read_transform(JsonReader& r) {
  Transform t;
  t.translation = r.vec3_of("translation", t.translation, finite);
  const bool euler = r.has("rotation_degrees"), quaternion = r.has("quaternion");
  if (euler && quaternion) r.error("give either \"rotation_degrees\" or \"quaternion\", not both");
  if (euler) t.rotation = Transform::rotation_from_euler_degrees(r.vec3_of("rotation_degrees", vec3(0.0f), finite));
  if (quaternion) {
    const vec4 q = r.vec4_of("quaternion", vec4(0.0f, 0.0f, 0.0f, 1.0f), finite);
    const float len = glm::length(q);
    if (len > 0.0f && std::isfinite(len)) {
      t.rotation = quat(q.w / len, q.x / len, q.y / len, q.z / len);
    } else {
      r.error_at("quaternion", "a rotation quaternion must not be zero");
    }
  }
  if (const nlohmann::json* s = r.value("scale")) {
    if (s->is_number()) {
      const float v = float(s->get<double>());
      if (!std::isfinite(v) || v == 0.0f) r.error_at("scale", fmt::format("{} is not a usable scale (finite, non-zero)", s->get<double>()));
      else t.scale = vec3(v);
    } else if (s->is_array() && s->size() == 3 && std::all_of(s->begin(), s->end(), [](const auto& e) { return e.is_number(); })) {
      const vec3 v = r.vec3_of("scale", vec3(1.0f), finite);
      if (v.x == 0.0f || v.y == 0.0f || v.z == 0.0f) r.error_at("scale", "no scale component may be zero");
      else t.scale = v;
    } else {
      r.error_at("scale", fmt::format("expected a number or an array of 3 numbers, got {}",
                                      s->is_array() ? fmt::format("an array of {}", s->size()) : std::string(json_type_name(*s))));
    }
  }
  r.finish();
  return t;
}

template <class T>
std::string known_names(const std::vector<T>& items) {
  std::vector<std::string> names;
  for (const T& item : items) names.push_back(item.name);
  return names.empty() ? std::string("none") : fmt::format("{}", fmt::join(names, ", "));
}

template <class T>
std::optional<std::uint32_t> find_named(const std::vector<T>& items, std::string_view name) {
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (items[i].name == name) return static_cast<std::uint32_t>(i);
  }
  return std::nullopt;
}

std::string json_error_text(const std::exception& e) {
  std::string text = e.what();
  if (text.starts_with("[json.exception.")) {  // "[json.exception.parse_error.101] parse error at line ..."
    const auto close = text.find("] ");
    if (close != std::string::npos) text = text.substr(close + 2);
  }
  return text;
}

}  // namespace

Result<SceneDesc> parse_scene(std::string_view json_text, const std::filesystem::path& base_dir, std::string_view source) {
  try {
    // Deeper than any scene needs; repeated keys are refused rather than the last one kept.
    constexpr std::size_t max_scene_depth = 256;
    if (auto ok = detail::check_json_structure(json_text, max_scene_depth); !ok) {
      return fail(ErrorKind::Parse, "{}: {}", source, ok.error().message);
    }
    nlohmann::json root;
    try {
      root = nlohmann::json::parse(json_text.begin(), json_text.end());
    } catch (const nlohmann::json::exception& e) {
      return fail(ErrorKind::Parse, "{}: invalid JSON: {}", source, json_error_text(e));
    }
    JsonErrors errors;
    JsonReader r(root, "$", errors, base_dir);
    SceneDesc desc;
    if (!root.is_object()) {
      errors.add("$", fmt::format("a scene file is a JSON object, got {}", json_type_name(root)));
      return std::unexpected(errors.to_error(source));
    }
    if (const nlohmann::json* v = r.value("version")) {
      if (!v->is_number_integer() || v->get<std::int64_t>() != 1) {
        r.error_at("version", fmt::format("unsupported version {} (this weft reads version 1)", v->dump()));
      }
    }
    (void)r.string("description");
    if (auto o = r.object("output")) desc.output = read_output(*o);
    desc.pipeline = r.path("pipeline");
    if (!desc.pipeline.empty() && detail::lowercase_extension(desc.pipeline) != ".json")
      r.error_at("pipeline", fmt::format("'{}' is not a .json pipeline file", desc.pipeline.string()));
    if (auto c = r.object("camera")) desc.camera = read_camera(*c);
    if (auto e = r.object("environment")) desc.environment = read_environment(*e);
    std::size_t light_index = 0;
    for (JsonReader& l : r.array("lights")) {
      if (auto light = read_light(l, light_index)) desc.lights.push_back(std::move(*light));
      ++light_index;
    }
    if (auto meshes = r.object("meshes")) {
      for (auto& [name, m] : meshes->members()) desc.meshes.push_back(read_mesh_source(m, name));
    }
    if (auto materials = r.object("materials")) {
      for (auto& [name, m] : materials->members()) desc.materials.push_back(read_material(m, name));
    }
    std::size_t object_index = 0;
    for (JsonReader& o : r.array("objects")) {
      const std::size_t index = object_index++;
      if (!o.is_object()) {
        o.error(fmt::format("expected an object, got {}", json_type_name(o.json())));
        continue;
      }
      ObjectDesc obj;
      obj.name = o.string("name", fmt::format("object {}", index));
      o.require("mesh");
      const std::string mesh = o.string("mesh");
      const std::string material = o.string("material");
      bool resolved = !mesh.empty();
      if (!mesh.empty()) {
        if (auto i = find_named(desc.meshes, mesh)) {
          obj.mesh = *i;
        } else {
          o.error_at("mesh", fmt::format("object '{}' uses unknown mesh '{}' (meshes: {})", obj.name, mesh, known_names(desc.meshes)));
          resolved = false;
        }
      }
      if (const nlohmann::json* m = o.value("material"); m != nullptr && !m->is_string()) {
        resolved = false;  // the type error is already recorded
      } else if (m != nullptr) {
        if (auto i = find_named(desc.materials, material)) {
          obj.material = *i;
        } else {
          o.error_at("material", fmt::format("object '{}' uses unknown material '{}' (materials: {})", obj.name, material,
                                             known_names(desc.materials)));
          resolved = false;
        }
      } else if (auto i = find_named(desc.materials, "default")) {
        obj.material = *i;
      } else {
        Material fallback;
        fallback.name = "default";
        obj.material = static_cast<std::uint32_t>(desc.materials.size());
        desc.materials.push_back(std::move(fallback));
      }
      if (auto t = o.object("transform")) obj.transform = read_transform(*t);
      o.finish();
      if (resolved) desc.objects.push_back(std::move(obj));
    }
    r.finish();
    if (!errors.empty()) return std::unexpected(errors.to_error(source));
    return desc;
  } catch (const std::exception& e) {
    return fail(ErrorKind::Parse, "{}: {}", source, json_error_text(e));
  } catch (...) {
    return fail(ErrorKind::Internal, "{}: unknown exception while reading the scene", source);
  }
}

Result<SceneDesc> load_scene_file(const std::filesystem::path& path) {
  if (auto why = weft::binary_text_input(path, "scene file")) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = weft::read_input_file(path, "scene file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  auto desc = parse_scene(text, path.parent_path(), weft::format("scene '{}'", path.string()));
  if (!desc) return desc;
  desc->source = path;
  return desc;
}

}  // namespace weft::scene
