// From a loaded scene to raw and compressed SSDFs: merge the objects into world space, bake
// visibility, transform distances, compress — timing each stage.
module;
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;
import weft.core;
import weft.cluster;
import weft.scene;

namespace weft::ssdf {

Result<BakeMesh> merge_objects(const scene::Scene& scene, std::span<const std::uint32_t> objects) {
  BakeMesh merged;
  for (const std::uint32_t index : objects) {
    if (index >= scene.objects.size())
      return fail(ErrorKind::InvalidArgument, "SSDF bake: object {} asked for, but the scene has {}", index,
                  scene.objects.size());
    const auto& object = scene.objects[index];
    if (object.mesh >= scene.meshes.size())
      return fail(ErrorKind::InvalidArgument, "SSDF bake: object '{}' names mesh {}, but the scene has {}", object.name,
                  object.mesh, scene.meshes.size());
    const auto& mesh = scene.meshes[object.mesh];
    const auto base = static_cast<std::uint32_t>(merged.positions.size());
    const mat3 normal_matrix = glm::transpose(glm::inverse(mat3(object.transform)));
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      merged.positions.push_back(vec3(object.transform * vec4(mesh.positions[v], 1.0f)));
      const vec3 n = v < mesh.normals.size() ? normal_matrix * mesh.normals[v] : vec3(0.0f);
      merged.normals.push_back(glm::length(n) > 0.0f ? glm::normalize(n) : vec3(0.0f));
    }
    for (std::uint32_t i : mesh.indices) merged.indices.push_back(base + i);
  }
  if (merged.positions.empty()) return fail(ErrorKind::InvalidArgument, "SSDF bake: the scene has no vertices");
  return merged;
}

Result<BakeMesh> merge_scene(const scene::Scene& scene) {
  std::vector<std::uint32_t> all(scene.objects.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  return merge_objects(scene, all);
}

Result<ObjectBake> bake_objects(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                                const BakeOptions& options) {
  using clock = std::chrono::steady_clock;
  auto seconds = [](clock::time_point since) { return std::chrono::duration<double>(clock::now() - since).count(); };
  auto occluders = merge_scene(scene);
  if (!occluders) return std::unexpected(occluders.error());
  auto probed = merge_objects(scene, objects);
  if (!probed) return std::unexpected(probed.error());
  ObjectBake result;
  result.probes = std::move(*probed);
  const DirectionGrid grid(options.resolution);
  log::info(weft::format("SSDF bake: {} probed vertices of {} objects, {} occluder triangles, {} x {} directions",
                         result.probes.vertex_count(), objects.size(), occluders->triangle_count(), grid.resolution(),
                         grid.resolution()));
  auto start = clock::now();
  auto visibility = bake_visibility(*occluders, vertex_probes(result.probes), grid, options.visibility);
  if (!visibility) return std::unexpected(visibility.error());
  result.timings.visibility_s = seconds(start);
  start = clock::now();
  result.raw = signed_distances(grid, *visibility, options.visibility.threads, false, options.visibility.progress);
  result.timings.distance_s = seconds(start);
  visibility->visible = {};
  start = clock::now();
  auto compressed = compress(result.probes, result.raw, options.compression);
  if (!compressed) return std::unexpected(compressed.error());
  result.compressed = std::move(*compressed);
  result.timings.compression_s = seconds(start);
  log::info(weft::format("SSDF bake: visibility {:.2f} s, distance transform {:.2f} s, CPCA {:.2f} s",
                         result.timings.visibility_s, result.timings.distance_s, result.timings.compression_s));
  return result;
}

Result<Bake> bake(const scene::Scene& scene, const BakeOptions& options) {
  using clock = std::chrono::steady_clock;
  auto seconds = [](clock::time_point since) { return std::chrono::duration<double>(clock::now() - since).count(); };
  Bake result;
  auto merged = merge_scene(scene);
  if (!merged) return std::unexpected(merged.error());
  result.mesh = std::move(*merged);
  const DirectionGrid grid(options.resolution);
  log::info(weft::format("SSDF bake: {} vertices, {} triangles, {} x {} directions", result.mesh.vertex_count(),
                         result.mesh.triangle_count(), grid.resolution(), grid.resolution()));

  auto start = clock::now();
  auto visibility = bake_visibility(result.mesh, vertex_probes(result.mesh), grid, options.visibility);
  if (!visibility) return std::unexpected(visibility.error());
  result.timings.visibility_s = seconds(start);

  start = clock::now();
  result.raw = signed_distances(grid, *visibility, options.visibility.threads, false, options.visibility.progress);
  result.timings.distance_s = seconds(start);
  visibility->visible = {};

  start = clock::now();
  auto compressed = compress(result.mesh, result.raw, options.compression);
  if (!compressed) return std::unexpected(compressed.error());
  result.compressed = std::move(*compressed);
  result.timings.compression_s = seconds(start);
  log::info(weft::format("SSDF bake: visibility {:.2f} s, distance transform {:.2f} s, CPCA {:.2f} s",
                         result.timings.visibility_s, result.timings.distance_s, result.timings.compression_s));
  return result;
}

}  // namespace weft::ssdf
