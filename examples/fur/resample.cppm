// Mesh resampling for the fur example and benchmark: reach a chosen vertex count (the
// paper's 2,082-vertex teapot and 34,832-vertex bunny) by midpoint subdivision, then
// OpenMesh's quadric decimation. UV seams are kept: their vertices are locked.
module;
#include <algorithm>
#include <cstdint>
#include <expected>
#include <map>
#include <unordered_map>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
export module weft.example.fur_resample;
import weft.core;
import weft.scene;

export namespace weft::examples {

// Each triangle into four; new vertices interpolate position, normal and UV (a seam edge,
// stored twice with different UVs, gets two midpoints). Curvature and tangents recomputed.
Result<scene::Mesh> subdivide_midpoint(const scene::Mesh& in);
// Quadric decimation down to about `target` vertices (seam vertices are never moved).
Result<scene::Mesh> decimate(const scene::Mesh& in, std::size_t target);
// Subdivides until the mesh has at least `target` vertices, then decimates to `target`.
Result<scene::Mesh> resample(const scene::Mesh& in, std::size_t target);

}  // namespace weft::examples

namespace weft::examples {

namespace {
Result<scene::Mesh> finish(scene::Mesh m) {
  m.tangents.clear();
  m.curvature.clear();
  m.mean_curvature.clear();
  m.gaussian_curvature.clear();
  m.principal_curvatures.clear();
  if (auto ok = scene::prepare_mesh(m); !ok) return std::unexpected(ok.error());
  return m;
}
}  // namespace

Result<scene::Mesh> subdivide_midpoint(const scene::Mesh& in) {
  scene::Mesh m;
  m.name = in.name;
  m.positions = in.positions;
  m.normals = in.normals;
  m.uvs = in.uvs;
  const bool uvs = in.has_uvs(), normals = in.normals.size() == in.positions.size();
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> middle;
  auto mid = [&](std::uint32_t a, std::uint32_t b) {
    auto [it, inserted] = middle.try_emplace({std::min(a, b), std::max(a, b)}, std::uint32_t(m.positions.size()));
    if (inserted) {
      m.positions.push_back(0.5f * (m.positions[a] + m.positions[b]));
      if (normals) {
        const vec3 n = m.normals[a] + m.normals[b];
        m.normals.push_back(glm::dot(n, n) > 0.0f ? glm::normalize(n) : m.normals[a]);
      }
      if (uvs) m.uvs.push_back(0.5f * (m.uvs[a] + m.uvs[b]));
    }
    return it->second;
  };
  for (std::size_t t = 0; t + 2 < in.indices.size(); t += 3) {
    const std::uint32_t a = in.indices[t], b = in.indices[t + 1], c = in.indices[t + 2];
    const std::uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    m.indices.insert(m.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  return finish(std::move(m));
}

Result<scene::Mesh> decimate(const scene::Mesh& in, std::size_t target) {
  using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;
  OMesh om;
  om.request_vertex_texcoords2D();
  om.request_vertex_status();
  om.request_edge_status();
  om.request_face_status();
  std::vector<OMesh::VertexHandle> handles;
  handles.reserve(in.positions.size());
  for (std::size_t i = 0; i < in.positions.size(); ++i) {
    const vec3 p = in.positions[i];
    handles.push_back(om.add_vertex(OMesh::Point(p.x, p.y, p.z)));
    if (in.has_uvs()) om.set_texcoord2D(handles.back(), OMesh::TexCoord2D(in.uvs[i].x, in.uvs[i].y));
  }
  for (std::size_t t = 0; t + 2 < in.indices.size(); t += 3)
    om.add_face(handles[in.indices[t]], handles[in.indices[t + 1]], handles[in.indices[t + 2]]);  // non-manifold: skipped
  for (auto v : om.vertices())
    if (om.is_boundary(v)) om.status(v).set_locked(true);
  OpenMesh::Decimater::DecimaterT<OMesh> decimater(om);
  OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
  decimater.add(quadric);
  decimater.module(quadric).unset_max_err();
  if (!decimater.initialize()) return fail(ErrorKind::Internal, "mesh '{}': OpenMesh decimater did not initialise", in.name);
  decimater.decimate_to(target);
  om.garbage_collection();
  scene::Mesh out;
  out.name = in.name;
  std::unordered_map<int, std::uint32_t> index;  // skip vertices no face uses
  for (auto f : om.faces())
    for (auto v : om.fv_range(f)) {
      auto [it, inserted] = index.try_emplace(v.idx(), std::uint32_t(out.positions.size()));
      if (inserted) {
        const auto p = om.point(v);
        out.positions.push_back(vec3(p[0], p[1], p[2]));
        if (in.has_uvs()) {
          const auto uv = om.texcoord2D(v);
          out.uvs.push_back(vec2(uv[0], uv[1]));
        }
      }
      out.indices.push_back(it->second);
    }
  return finish(std::move(out));
}

Result<scene::Mesh> resample(const scene::Mesh& in, std::size_t target) {
  scene::Mesh m = in;
  while (m.vertex_count() < target) {
    auto finer = subdivide_midpoint(m);
    if (!finer) return finer;
    m = std::move(*finer);
  }
  if (m.vertex_count() == target) return m;
  return decimate(m, target);
}

}  // namespace weft::examples
