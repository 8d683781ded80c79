// From a loaded scene to raw and compressed SSDFs: merge the objects into world space, bake
// visibility, transform distances, compress — timing each stage.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.ssdf;

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

namespace {

double seconds_since(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Visibility of every probe vertex against the occluders, then its signed distances.
Result<cluster::Matrix> distances(const BakeMesh& occluders, const BakeMesh& probes, const BakeOptions& options,
                                  BakeTimings& timings) {
  const DirectionGrid grid(options.resolution);
  auto start = std::chrono::steady_clock::now();
  WEFT_TRY(auto visibility, bake_visibility(occluders, vertex_probes(probes), grid, options.visibility));
  timings.visibility_s = seconds_since(start);
  start = std::chrono::steady_clock::now();
  cluster::Matrix raw = signed_distances(grid, visibility, options.visibility.threads, false, options.visibility.progress);
  timings.distance_s = seconds_since(start);
  return raw;
}

Result<Compressed> compressed(const BakeMesh& probes, const cluster::Matrix& raw, const BakeOptions& options,
                              BakeTimings& timings) {
  const auto start = std::chrono::steady_clock::now();
  auto result = compress(probes, raw, options.compression);
  timings.compression_s = seconds_since(start);
  if (result)
    log::info(weft::format("SSDF bake: visibility {:.2f} s, distance transform {:.2f} s, CPCA {:.2f} s",
                           timings.visibility_s, timings.distance_s, timings.compression_s));
  return result;
}

}  // namespace

Result<ObjectBake> bake_object_distances(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                                         const BakeOptions& options) {
  WEFT_TRY(auto occluders, merge_scene(scene));
  WEFT_TRY(auto probed, merge_objects(scene, objects));
  ObjectBake result;
  result.probes = std::move(probed);
  log::info(weft::format("SSDF bake: {} probed vertices of {} objects, {} occluder triangles, {} x {} directions",
                         result.probes.vertex_count(), objects.size(), occluders.triangle_count(),
                         std::max(1u, options.resolution), std::max(1u, options.resolution)));
  WEFT_TRY(auto raw, distances(occluders, result.probes, options, result.timings));
  result.raw = std::move(raw);
  return result;
}

Result<ObjectBake> bake_objects(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                                const BakeOptions& options) {
  auto result = bake_object_distances(scene, objects, options);
  if (!result) return result;
  WEFT_TRY(auto c, compressed(result->probes, result->raw, options, result->timings));
  result->compressed = std::move(c);
  return result;
}

Result<Bake> bake(const scene::Scene& scene, const BakeOptions& options) {
  Bake result;
  WEFT_TRY(auto merged, merge_scene(scene));
  result.mesh = std::move(merged);
  log::info(weft::format("SSDF bake: {} vertices, {} triangles, {} x {} directions", result.mesh.vertex_count(),
                         result.mesh.triangle_count(), std::max(1u, options.resolution), std::max(1u, options.resolution)));
  // The whole scene is both what is probed and what occludes.
  WEFT_TRY(auto raw, distances(result.mesh, result.mesh, options, result.timings));
  result.raw = std::move(raw);
  WEFT_TRY(auto c, compressed(result.mesh, result.raw, options, result.timings));
  result.compressed = std::move(c);
  return result;
}

}  // namespace weft::ssdf
