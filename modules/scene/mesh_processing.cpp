// Mesh validation and repair, welding, normals, tangents, bounds and normalisation: the
// steps of prepare_mesh (curvature is in curvature.cpp).
module;
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>
#include <glm/glm.hpp>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

bool finite(const vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const vec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(const vec4& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w); }

// The angle between two vectors, robust for tiny and nearly parallel ones.
float angle_between(const vec3& a, const vec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

// A triangle with a repeated index, or whose height is below 1e-7 of its longest edge
// (zero area to float precision), computed in double so the test itself does not round.
bool degenerate(const std::vector<vec3>& p, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  if (a == b || b == c || a == c) return true;
  const glm::dvec3 pa(p[a]), pb(p[b]), pc(p[c]);
  const glm::dvec3 e1 = pb - pa, e2 = pc - pa, e3 = pc - pb;
  const double longest2 = std::max({glm::dot(e1, e1), glm::dot(e2, e2), glm::dot(e3, e3)});
  const double twice_area = glm::length(glm::cross(e1, e2));
  return !(longest2 > 0.0) || !(twice_area > 1e-7 * longest2);
}

struct PositionKey {
  std::array<std::uint32_t, 3> bits;
  bool operator==(const PositionKey&) const = default;
};
struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (std::uint32_t b : k.bits) h = (h ^ b) * 0x100000001b3ull;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

}  // namespace

Bounds Bounds::transformed(const mat4& m) const {
  Bounds out;
  if (empty()) return out;
  for (int i = 0; i < 8; ++i) {
    const vec3 corner{(i & 1) ? max.x : min.x, (i & 2) ? max.y : min.y, (i & 4) ? max.z : min.z};
    out.extend(vec3(m * vec4(corner, 1.0f)));
  }
  return out;
}

Bounds compute_bounds(std::span<const vec3> positions) {
  Bounds b;
  for (const vec3& p : positions) b.extend(p);
  return b;
}

void normalize_to_unit_box(Mesh& mesh) {
  const Bounds b = compute_bounds(mesh.positions);
  if (b.empty()) return;
  const vec3 extent = b.size();
  const float largest = std::max({extent.x, extent.y, extent.z});
  const float scale = largest > 0.0f ? 1.0f / largest : 1.0f;
  const vec3 center = b.center();
  for (vec3& p : mesh.positions) p = (p - center) * scale;
  mesh.bounds = compute_bounds(mesh.positions);
}

namespace detail {

Welding weld(std::span<const vec3> positions) {
  Welding w;
  w.of.resize(positions.size());
  std::unordered_map<PositionKey, std::uint32_t, PositionKeyHash> first;
  first.reserve(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const vec3 p = positions[i] + vec3(0.0f);  // -0 + 0 = +0: one key for both zeros
    const PositionKey key{{std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y),
                           std::bit_cast<std::uint32_t>(p.z)}};
    auto [it, inserted] = first.try_emplace(key, static_cast<std::uint32_t>(w.positions.size()));
    if (inserted) w.positions.push_back(positions[i]);
    w.of[i] = it->second;
  }
  return w;
}

vec3 any_orthogonal(const vec3& n) {
  const vec3 axis = std::abs(n.x) < 0.9f ? vec3(1.0f, 0.0f, 0.0f) : vec3(0.0f, 1.0f, 0.0f);
  return glm::normalize(axis - n * glm::dot(n, axis));
}

}  // namespace detail

void compute_normals(Mesh& mesh) {
  const detail::Welding w = detail::weld(mesh.positions);
  std::vector<glm::dvec3> sum(w.positions.size(), glm::dvec3(0.0));
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    if (mesh.indices[t] >= w.of.size() || mesh.indices[t + 1] >= w.of.size() || mesh.indices[t + 2] >= w.of.size()) continue;
    const std::uint32_t v[3] = {w.of[mesh.indices[t]], w.of[mesh.indices[t + 1]], w.of[mesh.indices[t + 2]]};
    const vec3 p[3] = {w.positions[v[0]], w.positions[v[1]], w.positions[v[2]]};
    const vec3 face = glm::cross(p[1] - p[0], p[2] - p[0]);
    const float len = glm::length(face);
    if (!(len > 0.0f) || !std::isfinite(len)) continue;
    const vec3 n = face / len;
    for (int k = 0; k < 3; ++k) {
      const float angle = angle_between(p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
      sum[v[k]] += glm::dvec3(n) * double(angle);
    }
  }
  mesh.normals.resize(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::dvec3 s = sum[w.of[i]];
    const double len = glm::length(s);
    mesh.normals[i] = len > 1e-20 && std::isfinite(len) ? vec3(s / len) : vec3(0.0f, 1.0f, 0.0f);
  }
}

void compute_tangents(Mesh& mesh) {
  if (mesh.normals.size() != mesh.positions.size()) compute_normals(mesh);
  if (mesh.uvs.size() != mesh.positions.size()) mesh.uvs.clear();
  const std::size_t n = mesh.positions.size();
  mesh.tangents.assign(n, vec4(1.0f, 0.0f, 0.0f, 1.0f));
  std::vector<glm::dvec3> tan(n, glm::dvec3(0.0)), bitan(n, glm::dvec3(0.0));
  if (mesh.has_uvs()) {
    // Lengyel's per-triangle tangent frame from the UV gradients, summed at the corners.
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      if (a >= n || b >= n || c >= n) continue;
      const glm::dvec3 e1 = glm::dvec3(mesh.positions[b]) - glm::dvec3(mesh.positions[a]);
      const glm::dvec3 e2 = glm::dvec3(mesh.positions[c]) - glm::dvec3(mesh.positions[a]);
      const glm::dvec2 d1 = glm::dvec2(mesh.uvs[b]) - glm::dvec2(mesh.uvs[a]);
      const glm::dvec2 d2 = glm::dvec2(mesh.uvs[c]) - glm::dvec2(mesh.uvs[a]);
      const double det = d1.x * d2.y - d2.x * d1.y;
      if (!(std::abs(det) > 1e-20) || !std::isfinite(det)) continue;
      const double r = 1.0 / det;
      const glm::dvec3 sdir = (e1 * d2.y - e2 * d1.y) * r;
      const glm::dvec3 tdir = (e2 * d1.x - e1 * d2.x) * r;
      for (std::uint32_t v : {a, b, c}) {
        tan[v] += sdir;
        bitan[v] += tdir;
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const vec3 nrm = mesh.normals[i];
    // Gram-Schmidt against the normal; where UVs gave nothing usable, any orthogonal vector.
    glm::dvec3 t = tan[i] - glm::dvec3(nrm) * glm::dot(glm::dvec3(nrm), tan[i]);
    const double len = glm::length(t);
    const double scale = glm::length(tan[i]);
    vec3 tangent = len > 1e-6 * scale && len > 1e-30 && std::isfinite(len) ? vec3(t / len) : detail::any_orthogonal(nrm);
    // glTF's rule: the bitangent w * cross(n, t) points to the image's top, the normal map's
    // +Y (green). With v = 0 the top row, that is -dP/dv.
    const float w = glm::dot(glm::dvec3(glm::cross(nrm, tangent)), bitan[i]) > 0.0 ? -1.0f : 1.0f;
    mesh.tangents[i] = vec4(tangent, w);
  }
}

namespace detail {

Result<void> prepare_mesh(Mesh& mesh, const LoadOptions& options, std::string_view label) {
  const std::size_t n = mesh.positions.size();
  if (n == 0) return fail(ErrorKind::InvalidArgument, "{}: the mesh has no vertices", label);
  if (mesh.indices.empty()) return fail(ErrorKind::InvalidArgument, "{}: the mesh has no triangles", label);
  if (n > 0xffffffffull) return fail(ErrorKind::Unsupported, "{}: more than 2^32 vertices", label);
  if (mesh.indices.size() % 3 != 0) {
    return fail(ErrorKind::Parse, "{}: {} indices is not a whole number of triangles", label, mesh.indices.size());
  }
  for (std::size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= n) {
      return fail(ErrorKind::Parse, "{}: triangle {} uses vertex {}, but the mesh has only {} vertices", label, i / 3,
                  mesh.indices[i], n);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const vec3& p = mesh.positions[i];
    if (!finite(p)) {
      return fail(ErrorKind::Parse, "{}: vertex {} has a non-finite position ({}, {}, {})", label, i, p.x, p.y, p.z);
    }
  }
  const auto check_size = [&](std::size_t size, std::string_view what) -> Result<void> {
    if (size != 0 && size != n) {
      return fail(ErrorKind::InvalidArgument, "{}: {} {} for {} vertices (need one per vertex or none)", label, size,
                  what, n);
    }
    return {};
  };
  if (auto r = check_size(mesh.normals.size(), "normals"); !r) return r;
  if (auto r = check_size(mesh.uvs.size(), "UVs"); !r) return r;
  if (auto r = check_size(mesh.uvs1.size(), "second-set UVs"); !r) return r;
  if (auto r = check_size(mesh.tangents.size(), "tangents"); !r) return r;

  // Repairs: each one is a warning.
  bool normals_needed = mesh.normals.empty() || options.recompute_normals;
  if (!normals_needed) {
    std::size_t bad = 0;
    for (vec3& nrm : mesh.normals) {
      const float len = glm::length(nrm);
      if (!finite(nrm) || !(len > 1e-12f) || !std::isfinite(len)) {
        ++bad;
      } else {
        nrm /= len;
      }
    }
    if (bad > 0) {
      warn(mesh.warnings, weft::format("{}: {} normals were not finite or had zero length; normals recomputed", label, bad));
      normals_needed = true;
    }
  }
  {
    std::size_t bad = 0;
    for (auto* set : {&mesh.uvs, &mesh.uvs1}) {
      for (vec2& uv : *set) {
        if (!finite(uv)) {
          uv = vec2(0.0f);
          ++bad;
        }
      }
    }
    if (bad > 0) warn(mesh.warnings, weft::format("{}: {} UVs were not finite; set to (0, 0)", label, bad));
  }
  bool tangents_needed = mesh.tangents.empty() || normals_needed;
  for (const vec4& t : mesh.tangents) {
    if (!finite(t)) {
      tangents_needed = true;
      break;
    }
  }
  {
    std::vector<std::uint32_t> kept;
    kept.reserve(mesh.indices.size());
    for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
      const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      if (degenerate(mesh.positions, a, b, c)) continue;
      kept.insert(kept.end(), {a, b, c});
    }
    const std::size_t removed = (mesh.indices.size() - kept.size()) / 3;
    if (kept.empty()) {
      return fail(ErrorKind::InvalidArgument, "{}: all {} triangles are degenerate (zero area or a repeated vertex)",
                  label, mesh.indices.size() / 3);
    }
    if (removed > 0) {
      warn(mesh.warnings,
           weft::format("{}: removed {} degenerate triangles (zero area or a repeated vertex)", label, removed));
      mesh.indices = std::move(kept);
    }
  }

  if (options.normalize_to_unit_box) normalize_to_unit_box(mesh);
  if (normals_needed) compute_normals(mesh);
  if (tangents_needed) {
    compute_tangents(mesh);
  } else {
    // Authored tangents (glTF): kept, made unit and orthogonal to the normal, w = +-1.
    for (std::size_t i = 0; i < n; ++i) {
      const vec3 nrm = mesh.normals[i];
      vec3 t = vec3(mesh.tangents[i]);
      t -= nrm * glm::dot(nrm, t);
      const float len = glm::length(t);
      t = len > 1e-6f ? t / len : any_orthogonal(nrm);
      mesh.tangents[i] = vec4(t, mesh.tangents[i].w < 0.0f ? -1.0f : 1.0f);
    }
  }
  const std::size_t refused = compute_curvature_counting(mesh);
  if (refused > 0) {
    warn(mesh.warnings, weft::format("{}: {} non-manifold faces (refused by OpenMesh) are kept for drawing but "
                                     "left out of mean and Gaussian curvature",
                                     label, refused));
  }
  mesh.bounds = compute_bounds(mesh.positions);
  return {};
}

}  // namespace detail

Result<void> prepare_mesh(Mesh& mesh, const LoadOptions& options) {
  return detail::prepare_mesh(mesh, options, weft::format("mesh '{}'", mesh.name));
}

}  // namespace weft::scene
