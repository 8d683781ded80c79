// Per-vertex curvature on the welded surface (vertices with equal positions are one, so UV
// seams and hard edges do not cut it):
// - skin curvature |dn|/|dp| (d'Eon & Luebke, GPU Gems 3 ch. 14; what the pre-integrated
//   skin LUT is indexed by): the mean over a vertex's edges of |n_i - n_j| / |p_i - p_j|;
// - mean curvature H from the cotangent Laplacian and Gaussian curvature K from the angle
//   defect, both over the mixed Voronoi area (Meyer, Desbrun, Schroeder & Barr 2003);
// - principal curvatures k1,2 = H +- sqrt(max(H^2 - K, 0)).
// OpenMesh holds the topology: it refuses non-manifold faces (counted, left out of H and K)
// and tells boundary vertices, whose H and K are the mean of their interior neighbours'
// (the Laplacian and the angle defect mean something else on a boundary).
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>
#include <glm/glm.hpp>
#include "openmesh.h"
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

constexpr double two_pi = 6.283185307179586476925;
constexpr double half_pi = 1.570796326794896619231;

float finite_or_zero(double v) {
  const auto f = static_cast<float>(v);
  return std::isfinite(f) ? f : 0.0f;
}

}  // namespace

namespace detail {

std::size_t compute_curvature_counting(Mesh& mesh) {
  const std::size_t n = mesh.positions.size();
  if (mesh.normals.size() != n) compute_normals(mesh);
  mesh.curvature.assign(n, 0.0f);
  mesh.mean_curvature.assign(n, 0.0f);
  mesh.gaussian_curvature.assign(n, 0.0f);
  mesh.principal_curvatures.assign(n, vec2(0.0f));
  if (n == 0) return 0;

  const Welding w = weld(mesh.positions);
  const std::size_t m = w.positions.size();
  std::vector<glm::dvec3> normal(m, glm::dvec3(0.0));
  for (std::size_t i = 0; i < n; ++i) normal[w.of[i]] += glm::dvec3(mesh.normals[i]);
  for (glm::dvec3& nrm : normal) {
    const double len = glm::length(nrm);
    nrm = len > 1e-20 ? nrm / len : glm::dvec3(0.0);
  }

  std::vector<std::array<std::uint32_t, 3>> triangles;
  triangles.reserve(mesh.indices.size() / 3);
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    if (mesh.indices[t] >= n || mesh.indices[t + 1] >= n || mesh.indices[t + 2] >= n) continue;
    const std::array<std::uint32_t, 3> tri{w.of[mesh.indices[t]], w.of[mesh.indices[t + 1]], w.of[mesh.indices[t + 2]]};
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
    triangles.push_back(tri);
  }

  // Skin curvature over every edge of every triangle (non-manifold ones too).
  std::vector<double> skin_sum(m, 0.0);
  std::vector<std::uint32_t> skin_count(m, 0);
  {
    std::vector<std::uint64_t> edges;
    edges.reserve(triangles.size() * 3);
    for (const auto& tri : triangles) {
      for (int k = 0; k < 3; ++k) {
        const std::uint64_t a = tri[k], b = tri[(k + 1) % 3];
        edges.push_back(std::min(a, b) << 32 | std::max(a, b));
      }
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (std::uint64_t e : edges) {
      const auto a = static_cast<std::uint32_t>(e >> 32), b = static_cast<std::uint32_t>(e & 0xffffffffu);
      const double dp = glm::length(glm::dvec3(w.positions[a]) - glm::dvec3(w.positions[b]));
      if (!(dp > 0.0)) continue;
      const double k = glm::length(normal[a] - normal[b]) / dp;
      skin_sum[a] += k;
      skin_sum[b] += k;
      ++skin_count[a];
      ++skin_count[b];
    }
  }

  // Topology through OpenMesh; it refuses faces that would make the surface non-manifold.
  om::TriMesh topology;
  topology.reserve(m, triangles.size() * 3 / 2 + 3, triangles.size());
  std::vector<om::TriMesh::VertexHandle> handles(m);
  for (std::size_t v = 0; v < m; ++v) {
    const vec3& p = w.positions[v];
    handles[v] = topology.add_vertex(om::TriMesh::Point(p.x, p.y, p.z));
  }
  std::size_t refused = 0;
  std::vector<std::array<std::uint32_t, 3>> accepted;
  accepted.reserve(triangles.size());
  {
    om::QuietStreams quiet;  // OpenMesh prints "complex edge/vertex" for every refusal
    for (const auto& tri : triangles) {
      const auto fh = topology.add_face(handles[tri[0]], handles[tri[1]], handles[tri[2]]);
      if (fh.is_valid()) {
        accepted.push_back(tri);
      } else {
        ++refused;
      }
    }
  }

  std::vector<glm::dvec3> laplacian(m, glm::dvec3(0.0));
  std::vector<double> area(m, 0.0), angle_sum(m, 0.0);
  for (const auto& tri : accepted) {
    const glm::dvec3 p[3] = {glm::dvec3(w.positions[tri[0]]), glm::dvec3(w.positions[tri[1]]),
                             glm::dvec3(w.positions[tri[2]])};
    double angle[3], cot[3];
    bool flat = false;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
      const double cross = glm::length(glm::cross(u, v)), dot = glm::dot(u, v);
      if (!(cross > 0.0)) flat = true;
      angle[k] = std::atan2(cross, dot);
      cot[k] = cross > 0.0 ? dot / cross : 0.0;
    }
    if (flat) continue;
    const double tri_area = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    // Cotangent Laplacian: the edge (i, j) is weighted by the cotangent of the opposite angle.
    for (int k = 0; k < 3; ++k) {
      const int i = k, j = (k + 1) % 3, o = (k + 2) % 3;
      laplacian[tri[i]] += cot[o] * (p[i] - p[j]);
      laplacian[tri[j]] += cot[o] * (p[j] - p[i]);
    }
    // Mixed Voronoi area: Voronoi for non-obtuse triangles, else half/quarter of the area.
    const bool obtuse = angle[0] > half_pi || angle[1] > half_pi || angle[2] > half_pi;
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3, l = (k + 2) % 3;
      if (!obtuse) {
        const glm::dvec3 eij = p[k] - p[j], eil = p[k] - p[l];
        area[tri[k]] += (glm::dot(eij, eij) * cot[l] + glm::dot(eil, eil) * cot[j]) / 8.0;
      } else {
        area[tri[k]] += angle[k] > half_pi ? tri_area / 2.0 : tri_area / 4.0;
      }
      angle_sum[tri[k]] += angle[k];
    }
  }

  std::vector<double> mean(m, 0.0), gauss(m, 0.0);
  std::vector<char> interior(m, 0);
  for (std::size_t v = 0; v < m; ++v) {
    const auto vh = handles[v];
    if (topology.is_isolated(vh) || !(area[v] > 0.0)) continue;
    const glm::dvec3 hn = laplacian[v] / (4.0 * area[v]);  // H times the unit normal
    if (!topology.is_boundary(vh)) {
      interior[v] = 1;
      mean[v] = glm::dot(hn, normal[v]) < 0.0 ? -glm::length(hn) : glm::length(hn);
      gauss[v] = (two_pi - angle_sum[v]) / area[v];
    } else {
      mean[v] = glm::dot(hn, normal[v]);  // replaced below when an interior neighbour exists
    }
  }
  for (std::size_t v = 0; v < m; ++v) {
    const auto vh = handles[v];
    if (interior[v] || topology.is_isolated(vh)) continue;
    double h = 0.0, k = 0.0;
    int count = 0;
    for (const auto nb : topology.vv_range(vh)) {
      const auto j = static_cast<std::size_t>(nb.idx());
      if (!interior[j]) continue;
      h += mean[j];
      k += gauss[j];
      ++count;
    }
    if (count > 0) {
      mean[v] = h / count;
      gauss[v] = k / count;
    }
  }

  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t v = w.of[i];
    const double h = mean[v], k = gauss[v];
    const double spread = std::sqrt(std::max(h * h - k, 0.0));
    mesh.curvature[i] = skin_count[v] > 0 ? finite_or_zero(skin_sum[v] / skin_count[v]) : 0.0f;
    mesh.mean_curvature[i] = finite_or_zero(h);
    mesh.gaussian_curvature[i] = finite_or_zero(k);
    mesh.principal_curvatures[i] = vec2(finite_or_zero(h + spread), finite_or_zero(h - spread));
  }
  return refused;
}

}  // namespace detail

void compute_curvature(Mesh& mesh) { (void)detail::compute_curvature_counting(mesh); }

}  // namespace weft::scene
