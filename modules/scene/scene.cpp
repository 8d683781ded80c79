// Loaded scenes: what a SceneDesc names (meshes, primitives, the environment), glTF scenes
// and single mesh files turned into a Scene, and the material type names.
module;
#include <algorithm>
#include <cstdint>
#include <exception>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>
#include <mutex>
#include <span>
#include <glm/glm.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
module weft.scene;
import weft.core;
import weft.image;

namespace weft::scene {
namespace {

// What a scene from a bare mesh or a light-less glTF gets: a key light from the upper
// front-left and a dim grey sky, so the result is visible without a scene file.
void add_default_lighting(Scene& scene) {
  if (scene.lights.empty()) {
    scene.lights.emplace_back(DirectionalLight{"key", glm::normalize(vec3(0.4f, -1.0f, -0.3f)), vec3(1.0f), 3.0f});
  }
  if (!scene.environment.map) scene.environment.constant_color = vec3(0.1f);
}

Result<Mesh> build_mesh(const MeshSource& src) {
  switch (src.primitive) {
    case PrimitiveKind::Sphere: return make_sphere(src.radius, src.segments);
    case PrimitiveKind::Plane: return make_plane(src.size, src.subdivisions);
    case PrimitiveKind::Torus: return make_torus(src.major_radius, src.minor_radius, src.segments, src.sides);
    case PrimitiveKind::Cube: return make_cube(src.size);
    case PrimitiveKind::None: break;
  }
  if (src.path.empty()) return fail(ErrorKind::InvalidArgument, "mesh '{}' has neither a path nor a primitive", src.name);
  return load_mesh(src.path, src.options);
}

}  // namespace

namespace {
struct MaterialTypeTable {
  std::mutex mutex;
  std::vector<std::pair<std::string, std::vector<std::string>>> types;  // name, aliases
};
MaterialTypeTable& material_types() {
  static MaterialTypeTable table;
  return table;
}
}  // namespace

Result<void> register_material_type(std::string_view name, std::span<const std::string> aliases) {
  auto& table = material_types();
  std::lock_guard lock(table.mutex);
  const std::vector<std::string> wanted(aliases.begin(), aliases.end());
  for (const auto& [known, known_aliases] : table.types)
    if (known == name) {
      if (known_aliases == wanted) return {};
      return fail(ErrorKind::InvalidArgument, "material type '{}' is already registered with other aliases", name);
    }
  std::vector<std::string_view> names{name};
  names.insert(names.end(), aliases.begin(), aliases.end());
  for (std::string_view n : names) {
    if (n.empty() || n == standard_material)
      return fail(ErrorKind::InvalidArgument, "material type '{}': '{}' cannot be a feature's type name", name, n);
    for (const auto& [known, known_aliases] : table.types)
      if (known == n || std::find(known_aliases.begin(), known_aliases.end(), n) != known_aliases.end())
        return fail(ErrorKind::InvalidArgument, "material type '{}': the name '{}' is taken by '{}'", name, n, known);
  }
  table.types.emplace_back(std::string(name), wanted);
  return {};
}

std::optional<std::string> resolve_material_type(std::string_view name) {
  if (name == standard_material) return std::string(standard_material);
  auto& table = material_types();
  std::lock_guard lock(table.mutex);
  for (const auto& [known, aliases] : table.types)
    if (known == name || std::find(aliases.begin(), aliases.end(), name) != aliases.end()) return known;
  return std::nullopt;
}

std::string known_material_types() {
  auto& table = material_types();
  std::lock_guard lock(table.mutex);
  std::string out(standard_material);
  for (const auto& [known, aliases] : table.types)
    out += aliases.empty() ? fmt::format(", {}", known) : fmt::format(", {} ({})", known, fmt::join(aliases, ", "));
  return out;
}

bool Scene::uses(std::string_view type) const {
  return std::any_of(objects.begin(), objects.end(), [&](const Object& o) {
    return o.material < materials.size() && materials[o.material].type == type;
  });
}

Bounds Scene::bounds() const {
  Bounds b;
  for (const Object& o : objects) {
    if (o.mesh < meshes.size()) b.extend(meshes[o.mesh].bounds.transformed(o.transform));
  }
  return b;
}

Result<Scene> load_scene(const SceneDesc& desc) {
  const std::string where = desc.source.empty() ? std::string("scene") : weft::format("scene '{}'", desc.source.string());
  try {
    Scene scene;
    scene.source = desc.source;
    scene.output = desc.output;
    scene.pipeline = desc.pipeline;
    scene.lights = desc.lights;
    scene.materials = desc.materials;
    scene.meshes.reserve(desc.meshes.size());
    for (const MeshSource& src : desc.meshes) {
      auto mesh = build_mesh(src);
      if (!mesh) return with_context(weft::format("{}: mesh '{}'", where, src.name), mesh.error());
      mesh->name = src.name;
      scene.warnings.insert(scene.warnings.end(), mesh->warnings.begin(), mesh->warnings.end());
      scene.meshes.push_back(std::move(*mesh));
    }
    for (const ObjectDesc& o : desc.objects) {
      if (o.mesh >= scene.meshes.size() || o.material >= scene.materials.size()) {
        return fail(ErrorKind::InvalidArgument, "{}: object '{}' names mesh {} / material {} out of range", where, o.name,
                    o.mesh, o.material);
      }
      scene.objects.push_back(Object{o.name, o.mesh, o.material, o.transform.matrix()});
    }
    const EnvironmentSource& env = desc.environment;
    if (!env.hdr.empty()) {
      auto loaded = load_environment(env.hdr);
      if (!loaded) return with_context(where, loaded.error());
      scene.environment = std::move(*loaded);
    }
    scene.environment.constant_color = env.color;
    scene.environment.intensity = env.intensity;
    scene.environment.rotation_degrees = env.rotation_degrees;
    scene.camera = desc.camera ? *desc.camera : camera_framing(scene.bounds());
    return scene;
  } catch (const std::exception& e) {
    return fail(ErrorKind::Internal, "{}: {}", where, e.what());
  }
}

Result<Scene> scene_from_gltf(GltfScene gltf) {
  Scene scene;
  scene.source = gltf.source;
  scene.meshes = std::move(gltf.meshes);
  scene.materials = std::move(gltf.materials);
  scene.objects = std::move(gltf.instances);
  scene.lights = std::move(gltf.lights);
  scene.warnings = std::move(gltf.warnings);
  scene.camera = gltf.cameras.empty() ? camera_framing(scene.bounds()) : gltf.cameras.front();
  add_default_lighting(scene);
  return scene;
}

Result<Scene> load_scene(const std::filesystem::path& path) {
  const std::string ext = detail::lowercase_extension(path);
  if (ext == ".json") {
    auto desc = load_scene_file(path);
    if (!desc) return std::unexpected(desc.error());
    return load_scene(*desc);
  }
  if (ext == ".gltf" || ext == ".glb") {
    auto gltf = load_gltf(path);
    if (!gltf) return std::unexpected(gltf.error());
    return scene_from_gltf(std::move(*gltf));
  }
  auto mesh = load_mesh(path);
  if (!mesh) return std::unexpected(mesh.error());
  Scene scene;
  scene.source = path;
  scene.warnings = mesh->warnings;
  scene.meshes.push_back(std::move(*mesh));
  Material material;
  material.name = "default";
  scene.materials.push_back(std::move(material));
  scene.objects.push_back(Object{path.stem().string(), 0, 0, mat4(1.0f)});
  scene.camera = camera_framing(scene.bounds());
  add_default_lighting(scene);
  return scene;
}

}  // namespace weft::scene
