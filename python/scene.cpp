// weft.Scene: a loaded scene (weft.scene), from a file, a dict, or built in code. Everything
// built in code goes through weft's scene reader as a fragment of a scene document
// ({"materials": {name: fields}}, {"lights": [...]}, ...), so the checks and the messages
// (with their JSON paths) are the scene file's. Materials are edited in place through
// Material views; a feature material's knobs are checked against the feature registry's
// knob table (the range written once, in the feature) and then by the feature's own
// material check, and a refused value leaves the material as it was.
#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <utility>
#include <variant>
#include <vector>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.feature;
import weft.tradeoff;
#include "common.h"

namespace weft::python {
namespace {

using SceneRef = std::shared_ptr<PyScene>;

std::filesystem::path base_dir_or_cwd(const std::optional<std::filesystem::path>& base_dir) {
  return base_dir ? *base_dir : std::filesystem::current_path();
}

// A scene document (or a fragment of one) read and loaded by weft.scene.
scene::Scene load_document(const json& document, const std::filesystem::path& base_dir, const std::string& source) {
  const std::string text = document.dump();
  Result<scene::Scene> loaded;
  {
    py::gil_scoped_release release;
    loaded = [&]() -> Result<scene::Scene> {
      auto desc = scene::parse_scene(text, base_dir, source);
      if (!desc) return std::unexpected(desc.error());
      return scene::load_scene(*desc);
    }();
  }
  return unwrap(std::move(loaded));
}

// Every feature material checked by its feature (the scene reader leaves a feature's fields to
// the feature, which the renderer asks at the first render): each bad material's problems at
// once, at load time, as one error.
void check_feature_materials(const scene::Scene& s) {
  std::vector<std::string> problems;
  for (const auto& m : s.materials) {
    if (m.type == scene::standard_material) continue;
    if (const FeatureDescriptor* f = feature_registry().find(m.type))
      if (auto ok = f->check_material(m); !ok) problems.push_back(ok.error().message);
  }
  unwrap(join_problems(problems));
}

std::shared_ptr<PyScene> loaded_scene(const std::filesystem::path& path) {
  Result<scene::Scene> loaded;
  {
    py::gil_scoped_release release;
    loaded = scene::load_scene(path);
  }
  auto s = std::make_shared<PyScene>();
  s->scene = unwrap(std::move(loaded));
  check_feature_materials(s->scene);
  return s;
}

py::tuple vec_tuple(const vec3& v) { return py::make_tuple(v.x, v.y, v.z); }

// ---- material fields -------------------------------------------------------------------------

// The fields of a standard material, by their scene-file names (docs/scene-format.md).
struct StandardField {
  const char* name;
  py::object (*get)(const scene::StandardMaterial&);
  void (*set)(scene::StandardMaterial&, const scene::StandardMaterial&);
};
py::object texture_value(const scene::Texture& t) {
  if (t.empty()) return py::none();
  if (!t.path.empty()) return py::str(t.path.string());
  return py::str(t.label);
}
const StandardField standard_fields[] = {
    {"base_color", [](const scene::StandardMaterial& m) -> py::object { return vec_tuple(m.base_color); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.base_color = v.base_color; }},
    {"alpha", [](const scene::StandardMaterial& m) -> py::object { return py::float_(m.alpha); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.alpha = v.alpha; }},
    {"metallic", [](const scene::StandardMaterial& m) -> py::object { return py::float_(m.metallic); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.metallic = v.metallic; }},
    {"roughness", [](const scene::StandardMaterial& m) -> py::object { return py::float_(m.roughness); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.roughness = v.roughness; }},
    {"normal_scale", [](const scene::StandardMaterial& m) -> py::object { return py::float_(m.normal_scale); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.normal_scale = v.normal_scale; }},
    {"occlusion_strength", [](const scene::StandardMaterial& m) -> py::object { return py::float_(m.occlusion_strength); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.occlusion_strength = v.occlusion_strength; }},
    {"emissive", [](const scene::StandardMaterial& m) -> py::object { return vec_tuple(m.emissive); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.emissive = v.emissive; }},
    {"base_color_texture", [](const scene::StandardMaterial& m) { return texture_value(m.base_color_texture); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.base_color_texture = v.base_color_texture; }},
    {"metallic_roughness_texture", [](const scene::StandardMaterial& m) { return texture_value(m.metallic_roughness_texture); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.metallic_roughness_texture = v.metallic_roughness_texture; }},
    {"normal_texture", [](const scene::StandardMaterial& m) { return texture_value(m.normal_texture); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.normal_texture = v.normal_texture; }},
    {"occlusion_texture", [](const scene::StandardMaterial& m) { return texture_value(m.occlusion_texture); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.occlusion_texture = v.occlusion_texture; }},
    {"emissive_texture", [](const scene::StandardMaterial& m) { return texture_value(m.emissive_texture); },
     [](scene::StandardMaterial& m, const scene::StandardMaterial& v) { m.emissive_texture = v.emissive_texture; }},
};
const StandardField* standard_field(std::string_view name) {
  for (const auto& f : standard_fields)
    if (name == f.name) return &f;
  return nullptr;
}
std::string standard_field_names() {
  std::string out;
  for (const auto& f : standard_fields) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

std::vector<std::string> dotted(std::string_view name) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= name.size(); ++i)
    if (i == name.size() || name[i] == '.') {
      parts.emplace_back(name.substr(start, i - start));
      start = i + 1;
    }
  return parts;
}
const json* find_at(const json& params, std::string_view name) {
  const json* at = &params;
  for (const auto& part : dotted(name)) {
    if (!at->is_object() || !at->contains(part)) return nullptr;
    at = &(*at)[part];
  }
  return at;
}
void set_at(json& params, std::string_view name, json value) {
  json* at = &params;
  for (const auto& part : dotted(name)) {
    if (!at->is_object()) *at = json::object();
    at = &(*at)[part];
  }
  *at = std::move(value);
}
bool erase_at(json& params, std::string_view name) {
  auto parts = dotted(name);
  json* at = &params;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    if (!at->is_object() || !at->contains(parts[i])) return false;
    at = &(*at)[parts[i]];
  }
  return at->is_object() && at->erase(parts.back()) > 0;
}

// A material of a scene, by name (indices stay valid: materials are never removed).
struct MaterialView {
  SceneRef scene;
  std::uint32_t index = 0;

  const scene::Material& get() const { return scene->scene.materials.at(index); }
  const FeatureDescriptor* feature() const { return feature_registry().find(get().type); }
  std::string label() const { return weft::format("{} material '{}'", get().type, get().name); }
};

// The material with `fields` set, checked: knobs against the registry's table, then the whole
// material by its feature's check (or, for a standard material, by the scene reader).
scene::Material edited(const MaterialView& view, const json& fields) {
  scene::Material m = view.get();
  if (m.type == scene::standard_material) {
    json document = {{"materials", {{m.name, fields}}}};
    const auto parsed = unwrap(scene::parse_scene(document.dump(), m.base_dir.empty() ? std::filesystem::current_path() : m.base_dir,
                                                  weft::format("material '{}'", m.name)));
    const scene::StandardMaterial& values = parsed.materials.front().standard;
    for (const auto& [name, value] : fields.items()) {
      const StandardField* f = standard_field(name);
      if (!f) raise(ErrorKind::InvalidArgument, weft::format("{}: '{}' is not a standard material field ({})", view.label(), name,
                                                             standard_field_names()));
      f->set(m.standard, values);
    }
    return m;
  }
  const FeatureDescriptor* feature = view.feature();
  if (!feature) raise(ErrorKind::Internal, view.label() + ": no feature of this type is registered");
  if (!m.params.is_object()) m.params = json::object();
  for (const auto& [name, value] : fields.items()) {
    if (const Knob* knob = find_knob(feature->knobs, name); knob && !value.is_null()) {
      if (auto ok = tradeoff::check_knob_value(*knob, value); !ok)
        raise(ErrorKind::InvalidArgument, weft::format("{}: {}", view.label(), ok.error().message));
    }
    if (value.is_null()) erase_at(m.params, name);
    else set_at(m.params, name, value);
  }
  if (m.json_path.empty()) m.json_path = "$.materials." + m.name;
  unwrap(feature->check_material(m));
  return m;
}

void assign(const MaterialView& view, scene::Material m) {
  std::unique_lock lock(view.scene->mutex);
  view.scene->scene.materials.at(view.index) = std::move(m);
}

py::object field_value(const MaterialView& view, const std::string& name) {
  const scene::Material& m = view.get();
  if (m.type == scene::standard_material) {
    const StandardField* f = standard_field(name);
    if (!f) throw py::key_error(weft::format("{}: '{}' is not a standard material field ({})", view.label(), name, standard_field_names()));
    return f->get(m.standard);
  }
  if (const json* v = find_at(m.params, name)) return from_json(*v);
  std::string knobs;
  if (const auto* feature = view.feature())
    for (const auto& k : feature->knobs) knobs += (knobs.empty() ? "" : ", ") + k.name;
  throw py::key_error(weft::format("{} sets no '{}' (fields set: {}; the feature's knobs: {}); a knob left unset takes the "
                                   "render's quality preset (weft.presets('{}'))",
                                   view.label(), name, m.params.empty() ? std::string("none") : m.params.dump(),
                                   knobs.empty() ? std::string("none") : knobs, m.type));
}

py::list knob_list(const FeatureDescriptor* feature) {
  py::list out;
  if (!feature) return out;
  py::module_ weft_module = py::module_::import("weft");
  return weft_module.attr("knobs")(feature->name);
}

// ---- the scene -------------------------------------------------------------------------------

py::dict camera_dict(const scene::Camera& c) {
  py::dict d;
  d["position"] = vec_tuple(c.position);
  d["target"] = vec_tuple(c.target);
  d["up"] = vec_tuple(c.up);
  d["fov"] = c.fov_y_degrees;
  d["near"] = c.near;
  d["far"] = c.far;
  return d;
}

py::dict light_dict(const scene::Light& light) {
  py::dict d;
  std::visit(
      [&](const auto& l) {
        using T = std::decay_t<decltype(l)>;
        d["name"] = l.name;
        d["color"] = vec_tuple(l.color);
        d["intensity"] = l.intensity;
        if constexpr (std::is_same_v<T, scene::DirectionalLight>) {
          d["type"] = "directional";
          d["direction"] = vec_tuple(l.direction);
        } else if constexpr (std::is_same_v<T, scene::PointLight>) {
          d["type"] = "point";
          d["position"] = vec_tuple(l.position);
          d["range"] = l.range;
        } else {
          d["type"] = "spot";
          d["position"] = vec_tuple(l.position);
          d["direction"] = vec_tuple(l.direction);
          d["range"] = l.range;
          d["inner_cone"] = l.inner_cone_degrees;
          d["outer_cone"] = l.outer_cone_degrees;
        }
      },
      light);
  return d;
}

template <class T>
std::vector<T> rows_of(const py::object& array, py::ssize_t columns, const char* what, const std::string& mesh) {
  auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!a || a.ndim() != 2 || a.shape(1) != columns)
    raise(ErrorKind::InvalidArgument, weft::format("mesh '{}': {} must be an array of shape (n, {})", mesh, what, columns));
  std::vector<T> out(std::size_t(a.shape(0)));
  std::memcpy(static_cast<void*>(out.data()), a.data(), out.size() * sizeof(T));
  return out;
}

std::uint32_t add_mesh(PyScene& s, scene::Mesh mesh) {
  std::unique_lock lock(s.mutex);
  for (const auto& m : s.scene.meshes)
    if (m.name == mesh.name) raise(ErrorKind::InvalidArgument, weft::format("the scene already has a mesh '{}'", mesh.name));
  s.scene.meshes.push_back(std::move(mesh));
  return std::uint32_t(s.scene.meshes.size() - 1);
}

std::uint32_t index_of_mesh(const PyScene& s, const std::string& name) {
  for (std::size_t i = 0; i < s.scene.meshes.size(); ++i)
    if (s.scene.meshes[i].name == name) return std::uint32_t(i);
  std::string names;
  for (const auto& m : s.scene.meshes) names += (names.empty() ? "" : ", ") + m.name;
  raise(ErrorKind::InvalidArgument, weft::format("unknown mesh '{}' (meshes: {})", name, names.empty() ? "none" : names));
}
std::uint32_t index_of_material(const PyScene& s, const std::string& name) {
  for (std::size_t i = 0; i < s.scene.materials.size(); ++i)
    if (s.scene.materials[i].name == name) return std::uint32_t(i);
  std::string names;
  for (const auto& m : s.scene.materials) names += (names.empty() ? "" : ", ") + m.name;
  raise(ErrorKind::InvalidArgument, weft::format("unknown material '{}' (materials: {})", name, names.empty() ? "none" : names));
}

vec3 vec3_argument(const py::object& v, const char* what, float scalar_fill) {
  if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v)) {
    if (scalar_fill != scalar_fill) raise(ErrorKind::InvalidArgument, weft::format("{} must be 3 numbers", what));
    return vec3(v.cast<float>());
  }
  const json j = to_json(v);
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    raise(ErrorKind::InvalidArgument, weft::format("{} must be 3 numbers, got {}", what, j.dump()));
  vec3 out(j[0].get<float>(), j[1].get<float>(), j[2].get<float>());
  if (!std::isfinite(out.x) || !std::isfinite(out.y) || !std::isfinite(out.z))
    raise(ErrorKind::InvalidArgument, weft::format("{} must be finite, got {}", what, j.dump()));
  return out;
}

}  // namespace

void bind_scene(py::module_& m) {
  py::class_<MaterialView>(m, "Material", R"(A material of a scene, edited in place.

m[field] reads a field; m[field] = value sets it (None removes it: a knob left unset follows the
render's quality preset). A feature material's knobs are checked against the feature
registry's knob table and the feature's own material check; a standard material's fields
(base_color, alpha, metallic, roughness, normal_scale, occlusion_strength, emissive and the
*_texture paths) by weft's scene reader. A refused value raises ValueError with weft's message
and leaves the material unchanged. The next render re-prepares only what the change touches.)")
      .def_property_readonly("name", [](const MaterialView& v) { return v.get().name; }, "The material's name in the scene (str).")
      .def_property_readonly("type", [](const MaterialView& v) { return v.get().type; },
                             "Its type (str): 'standard' or a registered feature's name ('shell_fur', ...).")
      .def("__getitem__", &field_value, py::arg("field"), R"(m[field] -> value

A field of the material: a feature material's value as set in its fields (dotted names descend:
'lut.size'), a standard material's field (its default when the scene left it out). KeyError
naming the fields set and the feature's knobs when a feature material does not set it.)")
      .def(
          "get",
          [](const MaterialView& v, const std::string& field, py::object fallback) -> py::object {
            try {
              return field_value(v, field);
            } catch (const py::key_error&) {
              return fallback;
            }
          },
          py::arg("field"), py::arg("default") = py::none(), "get(field, default=None) -> value: m[field], or default when unset.")
      .def(
          "__setitem__",
          [](const MaterialView& v, const std::string& field, const py::object& value) {
            json fields = json::object();
            fields[field] = to_json(value);
            assign(v, edited(v, fields));
          },
          py::arg("field"), py::arg("value"), R"(m[field] = value

Sets one field after the checks above; ValueError (the registry's message, e.g. "knob 'layers':
1000 is not an integer in [1, 256]") when refused, and the material keeps its old value.)")
      .def(
          "__delitem__",
          [](const MaterialView& v, const std::string& field) {
            json fields = json::object();
            fields[field] = nullptr;
            if (v.get().type == scene::standard_material)
              raise(ErrorKind::InvalidArgument, v.label() + ": a standard material's fields cannot be removed; set them instead");
            assign(v, edited(v, fields));
          },
          py::arg("field"), "del m[field]: removes a feature material's field (a knob then follows the quality preset).")
      .def(
          "update",
          [](const MaterialView& v, const py::dict& fields) { assign(v, edited(v, to_json(fields))); }, py::arg("fields"),
          R"(update(fields: dict) -> None

Sets several fields at once, checked together: all are applied or none.)")
      .def(
          "__contains__",
          [](const MaterialView& v, const std::string& field) {
            if (v.get().type == scene::standard_material) return standard_field(field) != nullptr;
            return find_at(v.get().params, field) != nullptr;
          },
          py::arg("field"))
      .def_property_readonly(
          "params", [](const MaterialView& v) { return from_json(v.get().params); },
          "A copy of a feature material's fields as a dict ({} for a standard material).")
      .def(
          "knobs", [](const MaterialView& v) { return knob_list(v.feature()); },
          "knobs() -> list[dict]: the knobs of the material's feature (weft.knobs(type)); [] for a standard material.")
      .def("__repr__", [](const MaterialView& v) {
        const auto& mat = v.get();
        if (mat.type == scene::standard_material)
          return weft::format("<weft.Material '{}' standard base_color=({}, {}, {}) roughness={} metallic={}>", mat.name,
                              mat.standard.base_color.x, mat.standard.base_color.y, mat.standard.base_color.z,
                              mat.standard.roughness, mat.standard.metallic);
        return weft::format("<weft.Material '{}' {} {}>", mat.name, mat.type, mat.params.dump());
      });

  struct MaterialMap {
    SceneRef scene;
  };
  py::class_<MaterialMap>(m, "Materials", "The materials of a scene by name: scene.materials['fur'] is a weft.Material.")
      .def(
          "__getitem__",
          [](const MaterialMap& mm, const std::string& name) {
            std::shared_lock lock(mm.scene->mutex);
            for (std::size_t i = 0; i < mm.scene->scene.materials.size(); ++i)
              if (mm.scene->scene.materials[i].name == name) return MaterialView{mm.scene, std::uint32_t(i)};
            std::string names;
            for (const auto& mat : mm.scene->scene.materials) names += (names.empty() ? "" : ", ") + mat.name;
            throw py::key_error(weft::format("the scene has no material '{}' (materials: {})", name, names.empty() ? "none" : names));
          },
          py::arg("name"))
      .def("__len__", [](const MaterialMap& mm) { return mm.scene->scene.materials.size(); })
      .def("__contains__",
           [](const MaterialMap& mm, const std::string& name) {
             for (const auto& mat : mm.scene->scene.materials)
               if (mat.name == name) return true;
             return false;
           })
      .def("keys",
           [](const MaterialMap& mm) {
             std::vector<std::string> names;
             for (const auto& mat : mm.scene->scene.materials) names.push_back(mat.name);
             return names;
           })
      .def("__iter__",
           [](const MaterialMap& mm) {
             py::list names;
             for (const auto& mat : mm.scene->scene.materials) names.append(mat.name);
             return py::iter(names);
           })
      .def("__repr__", [](const MaterialMap& mm) {
        std::string names;
        for (const auto& mat : mm.scene->scene.materials) names += (names.empty() ? "" : ", ") + mat.name + " (" + mat.type + ")";
        return "<weft.Materials " + names + ">";
      });

  py::class_<PyScene, SceneRef>(m, "Scene", R"(A scene: meshes, materials, objects, lights, camera, environment (weft.scene).

weft.load_scene(path) reads a file (.json scene, .gltf/.glb, or a mesh file); Scene.from_dict(d)
reads a scene document given as a dict; Scene() starts an empty one to build in code with
add_mesh / add_primitive / add_material / add_object / add_light / set_environment and the
camera property. Renders read the scene as it is at the time of the call.)")
      .def(py::init([] { return std::make_shared<PyScene>(); }), R"(Scene() -> Scene

An empty scene: no meshes or objects, the default camera (at (0, 1, 5) looking at the origin),
a black constant environment, no lights, output size 1280x720.)")
      .def_static(
          "load",
          [](const std::filesystem::path& path) { return loaded_scene(path); },
          py::arg("path"), "Scene.load(path) -> Scene: the same as weft.load_scene(path).")
      .def_static(
          "from_dict",
          [](const py::dict& document, std::optional<std::filesystem::path> base_dir, const std::string& source) {
            auto s = std::make_shared<PyScene>();
            s->scene = load_document(to_json(document), base_dir_or_cwd(base_dir), source);
            check_feature_materials(s->scene);
            return s;
          },
          py::arg("document"), py::arg("base_dir") = py::none(), py::arg("source") = "scene dict",
          R"(Scene.from_dict(document, base_dir=None, source='scene dict') -> Scene

A scene document (the JSON scene format of docs/scene-format.md, as a dict) read by weft's
scene reader: relative paths resolve against base_dir (default: the working folder). Every
problem comes back at once in one ValueError, a line each with its JSON path
("$.materials.fur.layers: ..."), headed by `source`.)")
      .def(
          "copy",
          [](const PyScene& s) {
            auto out = std::make_shared<PyScene>();
            std::shared_lock lock(s.mutex);
            out->scene = s.scene;
            return out;
          },
          "copy() -> Scene: an independent deep copy (meshes, materials, ...).")
      .def_property_readonly("source", [](const PyScene& s) { return s.scene.source.string(); },
                             "The file the scene was read from ('' when built in code or from a dict).")
      .def_property(
          "size", [](const PyScene& s) { return py::make_tuple(s.scene.output.width, s.scene.output.height); },
          [](PyScene& s, const py::object& size) {
            const auto [w, h] = size_argument(size);
            if (w == 0) raise(ErrorKind::InvalidArgument, "size cannot be None");
            std::unique_lock lock(s.mutex);
            s.scene.output = {w, h};
          },
          "The output size (width, height) a render without size= uses.")
      .def_property(
          "camera", [](const PyScene& s) { return camera_dict(s.scene.camera); },
          [](PyScene& s, const py::dict& fields) {
            json document = {{"camera", to_json(fields)}};
            auto loaded = load_document(document, std::filesystem::current_path(), "camera");
            std::unique_lock lock(s.mutex);
            s.scene.camera = loaded.camera;
          },
          R"(The camera as a dict: position, target, up (3 numbers each), fov (vertical, degrees), near, far.
Assign a dict with the scene file's camera fields to move it; fields left out take their
defaults, bad ones raise ValueError with their JSON path ($.camera.fov: ...).)")
      .def_property_readonly(
          "lights",
          [](const PyScene& s) {
            py::list out;
            for (const auto& l : s.scene.lights) out.append(light_dict(l));
            return out;
          },
          "The lights, as dicts (type, name, color, intensity, direction/position, ...).")
      .def_property_readonly(
          "meshes",
          [](const PyScene& s) {
            py::list out;
            for (const auto& mesh : s.scene.meshes) {
              py::dict d;
              d["name"] = mesh.name;
              d["vertices"] = mesh.vertex_count();
              d["triangles"] = mesh.triangle_count();
              d["bounds"] = py::make_tuple(vec_tuple(mesh.bounds.min), vec_tuple(mesh.bounds.max));
              out.append(d);
            }
            return out;
          },
          "The meshes as dicts: name, vertices, triangles, bounds ((min xyz), (max xyz)).")
      .def_property_readonly(
          "objects",
          [](const PyScene& s) {
            py::list out;
            for (const auto& o : s.scene.objects) {
              py::dict d;
              d["name"] = o.name;
              d["mesh"] = s.scene.meshes.at(o.mesh).name;
              d["material"] = s.scene.materials.at(o.material).name;
              out.append(d);
            }
            return out;
          },
          "The objects as dicts: name, mesh, material (names).")
      .def_property_readonly("materials", [](const SceneRef& s) { return MaterialMap{s}; },
                             "The materials by name (weft.Materials): scene.materials['fur']['layers'] = 32.")
      .def_property_readonly("warnings", [](const PyScene& s) { return s.scene.warnings; },
                             "What loading repaired or could not do (list of str).")
      .def(
          "uses", [](const PyScene& s, const std::string& type) { return s.scene.uses(type); }, py::arg("material_type"),
          "uses(material_type) -> bool: whether an object draws with a material of this type ('shell_fur', ...).")
      .def(
          "add_mesh",
          [](PyScene& s, const std::string& name, const py::object& positions, const py::object& indices,
             const py::object& normals, const py::object& uvs) {
            scene::Mesh mesh;
            mesh.name = name;
            mesh.positions = rows_of<vec3>(positions, 3, "positions", name);
            auto idx = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(indices);
            if (!idx) raise(ErrorKind::InvalidArgument, weft::format("mesh '{}': indices must be an array of integers", name));
            for (py::ssize_t i = 0; i < idx.size(); ++i) {
              const std::int64_t v = idx.data()[i];
              if (v < 0 || v > std::int64_t(UINT32_MAX))
                raise(ErrorKind::InvalidArgument, weft::format("mesh '{}': index {} at position {} is out of range", name, v, i));
              mesh.indices.push_back(std::uint32_t(v));
            }
            if (!normals.is_none()) mesh.normals = rows_of<vec3>(normals, 3, "normals", name);
            if (!uvs.is_none()) mesh.uvs = rows_of<vec2>(uvs, 2, "uvs", name);
            unwrap(scene::prepare_mesh(mesh));
            return add_mesh(s, std::move(mesh));
          },
          py::arg("name"), py::arg("positions"), py::arg("indices"), py::arg("normals") = py::none(), py::arg("uvs") = py::none(),
          R"(add_mesh(name, positions, indices, normals=None, uvs=None) -> int

A triangle mesh from arrays: positions (n, 3) float, indices (m, 3) or (3m,) integers (counter-
clockwise front faces), optional normals (n, 3) and uvs (n, 2) (v = 0 at the image's top).
weft prepares it as it does a mesh file: validation (ValueError naming what is wrong),
repairs, normals when missing, tangents, curvature. Returns the mesh's index.)")
      .def(
          "add_mesh_file",
          [](PyScene& s, const std::string& name, const std::filesystem::path& path, bool normalize_to_unit_box,
             bool recompute_normals) {
            Result<scene::Mesh> loaded;
            {
              py::gil_scoped_release release;
              loaded = scene::load_mesh(path, {.recompute_normals = recompute_normals, .normalize_to_unit_box = normalize_to_unit_box});
            }
            auto mesh = unwrap(std::move(loaded));
            mesh.name = name;
            return add_mesh(s, std::move(mesh));
          },
          py::arg("name"), py::arg("path"), py::arg("normalize_to_unit_box") = false, py::arg("recompute_normals") = false,
          R"(add_mesh_file(name, path, normalize_to_unit_box=False, recompute_normals=False) -> int

A mesh from a file (.obj .ply .off .stl .gltf .glb). Returns the mesh's index;
FileNotFoundError / ValueError with weft's message when it cannot be read.)")
      .def(
          "add_primitive",
          [](PyScene& s, const std::string& name, const std::string& primitive, const py::kwargs& fields) {
            json mesh = to_json(fields);
            mesh["primitive"] = primitive;
            auto loaded = load_document({{"meshes", {{name, mesh}}}}, std::filesystem::current_path(), "add_primitive");
            return add_mesh(s, std::move(loaded.meshes.front()));
          },
          py::arg("name"), py::arg("primitive"),
          R"(add_primitive(name, primitive, **fields) -> int

A procedural mesh as the scene format names it: primitive 'sphere' (radius, segments), 'plane'
(size, subdivisions), 'torus' (major_radius, minor_radius, segments, sides) or 'cube' (size).
Bad fields raise ValueError with their JSON path ($.meshes.<name>.radius: ...).)")
      .def(
          "add_material",
          [](const SceneRef& s, const std::string& name, const std::string& type, std::optional<std::filesystem::path> base_dir,
             const py::kwargs& fields) {
            json material = to_json(fields);
            material["type"] = type;
            const auto dir = base_dir_or_cwd(base_dir);
            auto loaded = load_document({{"materials", {{name, material}}}}, dir, "add_material");
            scene::Material made = std::move(loaded.materials.front());
            if (made.type != scene::standard_material)
              if (const FeatureDescriptor* f = feature_registry().find(made.type)) unwrap(f->check_material(made));
            std::unique_lock lock(s->mutex);
            for (const auto& mat : s->scene.materials)
              if (mat.name == name) raise(ErrorKind::InvalidArgument, weft::format("the scene already has a material '{}'", name));
            s->scene.materials.push_back(std::move(made));
            return MaterialView{s, std::uint32_t(s->scene.materials.size() - 1)};
          },
          py::arg("name"), py::arg("type") = "standard", py::arg("base_dir") = py::none(),
          R"(add_material(name, type='standard', base_dir=None, **fields) -> Material

A material as the scene format writes it: a type ('standard' or a registered feature's name or
alias: 'shell_fur'/'fur', 'skin_sss', ...) and its fields (base_color=[1, 0, 0], roughness=0.3;
photo='fur.png', layers=32, ...). Paths resolve against base_dir (default: the working folder).
Checked by weft's scene reader and the feature's material check: ValueError naming each bad
field's JSON path. Returns the new weft.Material.)")
      .def(
          "add_object",
          [](PyScene& s, const std::string& mesh, const std::string& material, std::optional<std::string> name,
             const py::object& translation, const py::object& rotation_degrees, const py::object& scale) {
            scene::Transform t;
            t.translation = vec3_argument(translation, "translation", std::nanf(""));
            t.rotation = scene::Transform::rotation_from_euler_degrees(vec3_argument(rotation_degrees, "rotation_degrees", std::nanf("")));
            t.scale = vec3_argument(scale, "scale", 1.0f);
            std::unique_lock lock(s.mutex);
            scene::Object o;
            o.mesh = index_of_mesh(s, mesh);
            o.material = index_of_material(s, material);
            o.name = name ? *name : weft::format("object {}", s.scene.objects.size());
            o.transform = t.matrix();
            s.scene.objects.push_back(std::move(o));
            return s.scene.objects.size() - 1;
          },
          py::arg("mesh"), py::arg("material"), py::arg("name") = py::none(), py::arg("translation") = py::make_tuple(0, 0, 0),
          py::arg("rotation_degrees") = py::make_tuple(0, 0, 0), py::arg("scale") = 1.0,
          R"(add_object(mesh, material, name=None, translation=(0, 0, 0), rotation_degrees=(0, 0, 0), scale=1.0) -> int

Draws the named mesh with the named material, placed by translation, Euler rotation in
degrees (about X, then Y, then Z) and scale (a number or 3 numbers). Returns the object's index.)")
      .def(
          "add_light",
          [](PyScene& s, const std::string& type, const py::kwargs& fields) {
            json light = to_json(fields);
            light["type"] = type;
            auto loaded = load_document({{"lights", json::array({light})}}, std::filesystem::current_path(), "add_light");
            std::unique_lock lock(s.mutex);
            s.scene.lights.push_back(std::move(loaded.lights.front()));
            return s.scene.lights.size() - 1;
          },
          py::arg("type"),
          R"(add_light(type, **fields) -> int

A light as the scene format writes it: type 'directional' (direction, color, intensity in lux),
'point' (position, color, intensity in candela, range) or 'spot' (position, direction, color,
intensity, range, inner_cone, outer_cone in degrees). The first directional light casts the
shadow map. ValueError with the JSON path ($.lights[0].intensity: ...) for bad fields.)")
      .def(
          "clear_lights",
          [](PyScene& s) {
            std::unique_lock lock(s.mutex);
            s.scene.lights.clear();
          },
          "clear_lights() -> None: removes every light.")
      .def(
          "set_environment",
          [](PyScene& s, std::optional<std::filesystem::path> base_dir, const py::kwargs& fields) {
            auto loaded = load_document({{"environment", to_json(fields)}}, base_dir_or_cwd(base_dir), "set_environment");
            std::unique_lock lock(s.mutex);
            s.scene.environment = std::move(loaded.environment);
          },
          py::arg("base_dir") = py::none(),
          R"(set_environment(base_dir=None, **fields) -> None

The light from every direction, as the scene format writes it: hdr='sky.hdr' (an
equirectangular .hdr/.exr, resolved against base_dir) or color=[r, g, b], with intensity and
rotation (degrees about +Y).)")
      .def("__repr__", [](const PyScene& s) {
        return weft::format("<weft.Scene '{}': {} meshes, {} materials, {} objects, {} lights, {}x{}>",
                            s.scene.source.empty() ? std::string("(in code)") : s.scene.source.string(), s.scene.meshes.size(),
                            s.scene.materials.size(), s.scene.objects.size(), s.scene.lights.size(), s.scene.output.width,
                            s.scene.output.height);
      });

  m.def(
      "load_scene",
      [](const std::filesystem::path& path) { return loaded_scene(path); },
      py::arg("path"), R"(load_scene(path) -> Scene

Reads a scene: a .json scene file (docs/scene-format.md), a .gltf/.glb, or a mesh file (one
object, a default material, a key light). FileNotFoundError for a missing file; ValueError with
every problem of the file, each at its JSON path -- feature materials' fields included, checked
by their features now rather than at the first render.)");
}

}  // namespace weft::python
