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
#include <glm/glm.hpp>
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

std::string_view to_string(MaterialType type) {
  switch (type) {
    case MaterialType::Standard: return "standard";
    case MaterialType::Fur: return "fur";
    case MaterialType::Skin: return "skin";
    case MaterialType::NeuralBtf: return "neural_btf";
    case MaterialType::Ssdf: return "ssdf";
  }
  return "standard";
}

std::optional<MaterialType> material_type_from_string(std::string_view name) {
  for (MaterialType t : {MaterialType::Standard, MaterialType::Fur, MaterialType::Skin, MaterialType::NeuralBtf,
                         MaterialType::Ssdf}) {
    if (to_string(t) == name) return t;
  }
  return std::nullopt;
}

bool Scene::uses(MaterialType type) const {
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
