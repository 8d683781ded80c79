// Geometry for fur: silhouette fin edges and generated UVs for meshes that have none.
module;
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string_view>
#include <unordered_map>
#include <vector>
#include <glm/glm.hpp>
module weft.pass.shell_fur;

namespace weft::fur {

namespace {

struct PositionKey {
  std::uint32_t x, y, z;
  friend bool operator==(const PositionKey&, const PositionKey&) = default;
};
struct PositionHash {
  std::size_t operator()(const PositionKey& k) const {
    return std::size_t(Hasher{}.value(k.x).value(k.y).value(k.z).digest());
  }
};
PositionKey key_of(vec3 p) {
  // + 0.0f turns -0 into +0, so both weld.
  return {std::bit_cast<std::uint32_t>(p.x + 0.0f), std::bit_cast<std::uint32_t>(p.y + 0.0f),
          std::bit_cast<std::uint32_t>(p.z + 0.0f)};
}

bool finite(vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

std::vector<FurFinEdge> make_fin_edges(std::span<const vec3> positions, std::span<const vec3> normals,
                                       std::span<const vec2> uvs, std::span<const std::uint32_t> indices) {
  std::vector<std::uint32_t> welded(positions.size());
  {
    std::unordered_map<PositionKey, std::uint32_t, PositionHash> first;
    first.reserve(positions.size());
    for (std::uint32_t i = 0; i < positions.size(); ++i) welded[i] = first.try_emplace(key_of(positions[i]), i).first->second;
  }
  auto normal_of = [&](std::uint32_t i) { return i < normals.size() ? normals[i] : vec3(0.0f); };
  auto uv_of = [&](std::uint32_t i) { return i < uvs.size() ? uvs[i] : vec2(0.0f); };

  std::vector<FurFinEdge> edges;
  std::vector<std::uint8_t> faces;  // per edge: how many faces share it (first two are kept)
  std::unordered_map<std::uint64_t, std::uint32_t> index_of;
  index_of.reserve(indices.size());
  for (std::size_t t = 0; t + 2 < indices.size(); t += 3) {
    const std::array<std::uint32_t, 3> v{indices[t], indices[t + 1], indices[t + 2]};
    if (v[0] >= positions.size() || v[1] >= positions.size() || v[2] >= positions.size()) continue;
    const vec3 cross = glm::cross(positions[v[1]] - positions[v[0]], positions[v[2]] - positions[v[0]]);
    const float length = glm::length(cross);
    // Zero-area (or non-finite) triangles have no normal and no silhouette: no fins.
    if (!(length > 1e-20f) || !finite(cross)) continue;
    const vec3 face_normal = cross / length;
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = v[std::size_t(e)], b = v[std::size_t((e + 1) % 3)];
      const std::uint32_t wa = welded[a], wb = welded[b];
      if (wa == wb) continue;
      const std::uint64_t key = (std::uint64_t(std::min(wa, wb)) << 32) | std::max(wa, wb);
      auto [it, inserted] = index_of.try_emplace(key, std::uint32_t(edges.size()));
      if (inserted) {
        edges.push_back({positions[a], positions[b], normal_of(a), normal_of(b),
                         vec4(uv_of(a), uv_of(b)), face_normal, face_normal});
        faces.push_back(1);
      } else if (faces[it->second] == 1) {
        edges[it->second].face_normal_1 = face_normal;
        faces[it->second] = 2;
      }
    }
  }
  return edges;
}

std::string_view to_string(FurUvMapping mapping) {
  switch (mapping) {
    case FurUvMapping::Auto: return "auto";
    case FurUvMapping::Mesh: return "mesh";
    case FurUvMapping::Planar: return "planar";
    case FurUvMapping::Spherical: return "spherical";
  }
  return "?";
}

Result<void> generate_fur_uvs(scene::Mesh& mesh, FurUvMapping mapping) {
  if (mesh.positions.empty()) return fail(ErrorKind::InvalidArgument, "mesh '{}' has no vertices", mesh.name);
  if (mapping == FurUvMapping::Mesh) {
    if (mesh.has_uvs()) return {};
    return fail(ErrorKind::InvalidArgument,
                "mesh '{}' has no UVs, and fur samples its photo by UV; give the mesh UVs or set the material's "
                "\"uv_mapping\" to \"planar\", \"spherical\" or \"auto\"",
                mesh.name);
  }
  if (mapping == FurUvMapping::Auto && mesh.has_uvs()) return {};
  if (mesh.normals.size() != mesh.positions.size()) scene::compute_normals(mesh);
  const scene::Bounds bounds = scene::compute_bounds(mesh.positions);
  const vec3 extent = glm::max(bounds.size(), vec3(1e-20f));
  std::array<int, 3> axes{0, 1, 2};
  std::sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  if (mapping == FurUvMapping::Auto)
    mapping = extent[axes[2]] < 0.1f * extent[axes[0]] ? FurUvMapping::Planar : FurUvMapping::Spherical;

  mesh.uvs.resize(mesh.positions.size());
  if (mapping == FurUvMapping::Planar) {
    const float scale = 1.0f / extent[axes[0]];
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      const vec3 p = mesh.positions[i] - bounds.min;
      mesh.uvs[i] = vec2(p[axes[0]], p[axes[1]]) * scale;
    }
  } else {
    const vec3 centre = bounds.center();
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      vec3 d = mesh.positions[i] - centre;
      const float len = glm::length(d);
      d = len > 1e-20f && std::isfinite(len) ? d / len : vec3(0, 1, 0);
      mesh.uvs[i] = vec2((std::atan2(d.z, d.x) / (2.0f * pi) + 0.5f) * 2.0f, std::acos(std::clamp(d.y, -1.0f, 1.0f)) / pi);
    }
    // Triangles across the seam (u jumps from ~2 to ~0) get copies of their low-u vertices
    // at u + 2, so no triangle interpolates across the whole photo.
    std::unordered_map<std::uint32_t, std::uint32_t> copy_of;
    auto copy_vertex = [&](std::uint32_t i) {
      auto [it, inserted] = copy_of.try_emplace(i, std::uint32_t(mesh.positions.size()));
      if (!inserted) return it->second;
      auto dup = [i](auto& array) {
        if (i < array.size()) array.push_back(array[i]);
      };
      dup(mesh.positions);
      dup(mesh.normals);
      dup(mesh.tangents);
      dup(mesh.curvature);
      dup(mesh.mean_curvature);
      dup(mesh.gaussian_curvature);
      dup(mesh.principal_curvatures);
      mesh.uvs.push_back(mesh.uvs[i] + vec2(2.0f, 0.0f));
      return it->second;
    };
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      float lo = 1e30f, hi = -1e30f;
      for (int k = 0; k < 3; ++k) {
        lo = std::min(lo, mesh.uvs[mesh.indices[t + std::size_t(k)]].x);
        hi = std::max(hi, mesh.uvs[mesh.indices[t + std::size_t(k)]].x);
      }
      if (hi - lo <= 1.0f) continue;
      for (int k = 0; k < 3; ++k) {
        std::uint32_t& index = mesh.indices[t + std::size_t(k)];
        if (mesh.uvs[index].x < 1.0f) index = copy_vertex(index);
      }
    }
  }
  scene::compute_tangents(mesh);
  return {};
}

}  // namespace weft::fur
