// Mesh files: OBJ/PLY/OFF/STL through OpenMesh's readers, glTF through load_gltf (merged).
//
// OpenMesh reads into a polygon mesh with per-corner (halfedge) UVs and normals; faces are
// fanned into triangles here, and a vertex is split wherever its corners disagree on UV or
// normal. OpenMesh's importer trusts the reader's vertex references (a face naming vertex
// 9 of 4 indexes past its arrays), so weft reads through an importer that checks every
// handle first and turns bad references into a Parse error.
module;
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <expected>
#include <filesystem>
#include <new>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>
#include <fmt/format.h>
#include <glm/glm.hpp>
#include "openmesh.h"
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

using om::PolyMesh;
using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::VertexHandle;
namespace omio = OpenMesh::IO;

// OpenMesh's importer with every handle checked before use; counts what it refused.
class CheckedImporter final : public omio::ImporterT<PolyMesh> {
 public:
  using Base = omio::ImporterT<PolyMesh>;
  CheckedImporter(PolyMesh& mesh, std::size_t size_hint) : Base(mesh), mesh_(mesh), size_hint_(size_hint) {}

  std::size_t bad_references = 0;   // faces or attributes naming a vertex/face that is not there
  std::size_t repeated_vertex_faces = 0;
  std::size_t short_faces = 0;      // fewer than 3 corners
  std::size_t non_manifold_faces = 0;

  // OpenMesh leaves new properties uninitialised: every vertex and corner attribute this
  // importer could read is set here, so nothing the file did not give is garbage.
  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override { return cleared(Base::add_vertex(p)); }
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override { return cleared(Base::add_vertex(p)); }
  VertexHandle add_vertex() override { return cleared(Base::add_vertex()); }

  HalfedgeHandle add_edge(VertexHandle a, VertexHandle b) override {
    if (!ok(a) || !ok(b)) return bad<HalfedgeHandle>();
    return Base::add_edge(a, b);
  }
  FaceHandle add_face(const VHandles& corners) override {
    last_face_ = FaceHandle();
    last_copies_.clear();
    if (corners.size() < 3) {
      ++short_faces;
      corner_normals_.clear();
      return FaceHandle();
    }
    for (const VertexHandle v : corners) {
      if (!ok(v)) {
        corner_normals_.clear();
        return bad<FaceHandle>();
      }
    }
    for (std::size_t i = 0; i < corners.size(); ++i) {
      for (std::size_t j = i + 1; j < corners.size(); ++j) {
        if (corners[i] == corners[j]) {
          ++repeated_vertex_faces;
          corner_normals_.clear();
          return FaceHandle();
        }
      }
    }
    const std::size_t before = mesh_.n_vertices();
    const FaceHandle fh = Base::add_face(corners);
    if (mesh_.n_vertices() != before) {
      // Refused as non-manifold: the importer added the face on copies of its vertices, in
      // the order of `corners`. The copies take the originals' attributes.
      ++non_manifold_faces;
      for (std::size_t j = 0; j < corners.size() && before + j < mesh_.n_vertices(); ++j) {
        const VertexHandle copy(static_cast<int>(before + j));
        mesh_.set_normal(copy, mesh_.normal(corners[j]));
        mesh_.set_texcoord2D(copy, mesh_.texcoord2D(corners[j]));
        last_copies_.emplace_back(corners[j], copy);
      }
    }
    if (fh.is_valid()) {
      for (const auto heh : mesh_.fh_range(fh)) {
        VertexHandle v = mesh_.to_vertex_handle(heh);
        for (const auto& [original, copy] : last_copies_) {
          if (copy == v) v = original;
        }
        const auto it = std::find_if(corner_normals_.begin(), corner_normals_.end(),
                                     [&](const auto& entry) { return entry.first == v; });
        mesh_.set_normal(heh, it != corner_normals_.end() ? it->second : PolyMesh::Normal(0.0f, 0.0f, 0.0f));
        mesh_.set_texcoord2D(heh, PolyMesh::TexCoord2D(0.0f, 0.0f));
      }
      last_face_ = fh;
    }
    corner_normals_.clear();
    return fh;
  }
  FaceHandle add_face(HalfedgeHandle) override { return bad<FaceHandle>(); }  // OpenMesh's own format only

  void add_face_texcoords(FaceHandle f, VertexHandle v, const std::vector<OpenMesh::Vec2f>& t) override {
    if (!ok(f) || !ok(v)) {
      bad<int>();
      return;
    }
    if (f == last_face_) {
      for (const auto& [original, copy] : last_copies_) {
        if (original == v) v = copy;  // the face lies on copies: start at the copy
      }
    }
    Base::add_face_texcoords(f, v, t);
  }
  void add_face_texcoords(FaceHandle f, VertexHandle v, const std::vector<OpenMesh::Vec3f>& t) override {
    if (ok(f) && ok(v)) Base::add_face_texcoords(f, v, t);
    else bad<int>();
  }
  void set_face_texindex(FaceHandle f, int id) override {
    if (ok(f)) Base::set_face_texindex(f, id);
  }
  void set_point(VertexHandle v, const OpenMesh::Vec3f& p) override { if (ok(v)) Base::set_point(v, p); else bad<int>(); }
  void set_halfedge(VertexHandle v, HalfedgeHandle h) override { if (ok(v) && ok(h)) Base::set_halfedge(v, h); else bad<int>(); }
  void set_normal(VertexHandle v, const OpenMesh::Vec3f& n) override { set_vertex_normal(v, PolyMesh::Normal(n[0], n[1], n[2])); }
  void set_normal(VertexHandle v, const OpenMesh::Vec3d& n) override {
    set_vertex_normal(v, PolyMesh::Normal(float(n[0]), float(n[1]), float(n[2])));
  }
  void set_color(VertexHandle v, const OpenMesh::Vec3uc& c) override { if (ok(v)) Base::set_color(v, c); }
  void set_color(VertexHandle v, const OpenMesh::Vec4uc& c) override { if (ok(v)) Base::set_color(v, c); }
  void set_color(VertexHandle v, const OpenMesh::Vec3f& c) override { if (ok(v)) Base::set_color(v, c); }
  void set_color(VertexHandle v, const OpenMesh::Vec4f& c) override { if (ok(v)) Base::set_color(v, c); }
  void set_texcoord(VertexHandle v, const OpenMesh::Vec2f& t) override { if (ok(v)) Base::set_texcoord(v, t); else bad<int>(); }
  void set_texcoord(VertexHandle v, const OpenMesh::Vec3f& t) override { if (ok(v)) Base::set_texcoord(v, t); else bad<int>(); }
  void set_texcoord(HalfedgeHandle h, const OpenMesh::Vec2f& t) override { if (ok(h)) Base::set_texcoord(h, t); else bad<int>(); }
  void set_texcoord(HalfedgeHandle h, const OpenMesh::Vec3f& t) override { if (ok(h)) Base::set_texcoord(h, t); else bad<int>(); }
  void set_status(VertexHandle v, const OpenMesh::Attributes::StatusInfo& s) override { if (ok(v)) Base::set_status(v, s); }
  void set_status(HalfedgeHandle h, const OpenMesh::Attributes::StatusInfo& s) override { if (ok(h)) Base::set_status(h, s); }
  void set_status(EdgeHandle e, const OpenMesh::Attributes::StatusInfo& s) override { if (ok(e)) Base::set_status(e, s); }
  void set_status(FaceHandle f, const OpenMesh::Attributes::StatusInfo& s) override { if (ok(f)) Base::set_status(f, s); }
  void set_next(HalfedgeHandle h, HalfedgeHandle next) override { if (ok(h) && ok(next)) Base::set_next(h, next); else bad<int>(); }
  void set_face(HalfedgeHandle h, FaceHandle f) override { if (ok(h) && ok(f)) Base::set_face(h, f); else bad<int>(); }
  void set_color(EdgeHandle e, const OpenMesh::Vec3uc& c) override { if (ok(e)) Base::set_color(e, c); }
  void set_color(EdgeHandle e, const OpenMesh::Vec4uc& c) override { if (ok(e)) Base::set_color(e, c); }
  void set_color(EdgeHandle e, const OpenMesh::Vec3f& c) override { if (ok(e)) Base::set_color(e, c); }
  void set_color(EdgeHandle e, const OpenMesh::Vec4f& c) override { if (ok(e)) Base::set_color(e, c); }
  void set_normal(FaceHandle f, const OpenMesh::Vec3f& n) override { if (ok(f)) Base::set_normal(f, n); }
  void set_normal(FaceHandle f, const OpenMesh::Vec3d& n) override { if (ok(f)) Base::set_normal(f, n); }
  void set_color(FaceHandle f, const OpenMesh::Vec3uc& c) override { if (ok(f)) Base::set_color(f, c); }
  void set_color(FaceHandle f, const OpenMesh::Vec4uc& c) override { if (ok(f)) Base::set_color(f, c); }
  void set_color(FaceHandle f, const OpenMesh::Vec3f& c) override { if (ok(f)) Base::set_color(f, c); }
  void set_color(FaceHandle f, const OpenMesh::Vec4f& c) override { if (ok(f)) Base::set_color(f, c); }

  // A corrupt header may claim billions of elements; reserve no more than the file could hold.
  void reserve(unsigned int nv, unsigned int ne, unsigned int nf) override {
    const auto cap = static_cast<unsigned int>(std::min<std::size_t>(size_hint_, 1u << 26));
    Base::reserve(std::min(nv, cap), std::min(ne, cap), std::min(nf, cap));
  }

 private:
  VertexHandle cleared(VertexHandle v) {
    if (ok(v)) {
      mesh_.set_normal(v, PolyMesh::Normal(0.0f, 0.0f, 0.0f));
      mesh_.set_texcoord2D(v, PolyMesh::TexCoord2D(0.0f, 0.0f));
    }
    return v;
  }
  // A reader sets a vertex's normal just before each face it is a corner of (OBJ), or once
  // per vertex (PLY, OFF); the pending ones become the next face's corner normals.
  void set_vertex_normal(VertexHandle v, const PolyMesh::Normal& n) {
    if (!ok(v)) {
      bad<int>();
      return;
    }
    mesh_.set_normal(v, n);
    const auto it = std::find_if(corner_normals_.begin(), corner_normals_.end(), [&](const auto& e) { return e.first == v; });
    if (it != corner_normals_.end()) it->second = n;
    else if (corner_normals_.size() < 64) corner_normals_.emplace_back(v, n);
  }

  bool ok(VertexHandle v) const { return v.is_valid() && std::size_t(v.idx()) < mesh_.n_vertices(); }
  bool ok(HalfedgeHandle h) const { return h.is_valid() && std::size_t(h.idx()) < mesh_.n_halfedges(); }
  bool ok(EdgeHandle e) const { return e.is_valid() && std::size_t(e.idx()) < mesh_.n_edges(); }
  bool ok(FaceHandle f) const { return f.is_valid() && std::size_t(f.idx()) < mesh_.n_faces(); }
  template <class H>
  H bad() {
    ++bad_references;
    return H();
  }

  PolyMesh& mesh_;
  std::size_t size_hint_;
  std::vector<std::pair<VertexHandle, PolyMesh::Normal>> corner_normals_;
  FaceHandle last_face_;
  std::vector<std::pair<VertexHandle, VertexHandle>> last_copies_;
};

// One split vertex: an OpenMesh vertex with the UV and normal of one of its corners.
struct CornerKey {
  std::array<std::uint32_t, 6> bits;
  bool operator==(const CornerKey&) const = default;
};
struct CornerKeyHash {
  std::size_t operator()(const CornerKey& k) const {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (std::uint32_t b : k.bits) h = (h ^ b) * 0x100000001b3ull;
    return static_cast<std::size_t>(h ^ (h >> 31));
  }
};

// `contents`: the file as OpenMesh should read it, when weft rewrote it (PLY tristrips).
// An OFF file that check_off accepted, written out again the one way OpenMesh's reader is sure
// to parse: the keyword alone on the first line, the counts on the next, then each record on a
// line of single-spaced tokens, comments and blank lines dropped. OpenMesh's own header parse
// loses its place on layouts the format allows ("OFF  4 1 0", two spaces: an endless loop found
// by fuzz_off), so it never sees the original text.
Result<std::string> canonical_off(const std::filesystem::path& path) {
  auto bytes = weft::read_input_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  std::string out;
  bool keyword_done = false;
  bool free_dimension = false;      // nOFF: a dimension record comes before the counts
  std::size_t records = 0, vertices = 0;
  // Face records keep their corner count and indices only: OpenMesh reads what follows as a
  // colour and loops on junk there (fuzz_off); weft has no use for face colours.
  for (std::size_t pos = 0; pos < text.size();) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    std::string record;
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      if (j > i) {
        if (!keyword_done) {  // the keyword ends its own line; what follows it starts the next
          out.append(line.substr(i, j - i)).push_back('\n');
          free_dimension = line.substr(i, j - i).find('n') != std::string_view::npos;
          keyword_done = true;
        } else {
          if (!record.empty()) record.push_back(' ');
          record.append(line.substr(i, j - i));
        }
      }
      i = j;
    }
    if (record.empty()) continue;
    const std::size_t counts_record = free_dimension ? 1 : 0;
    if (records == counts_record) vertices = std::strtoull(record.c_str(), nullptr, 10);
    if (records > counts_record + vertices) {  // a face: its count, then that many indices
      const std::size_t corners = std::strtoull(record.c_str(), nullptr, 10);
      std::size_t at = 0;
      for (std::size_t k = 0; k <= corners && at != std::string::npos; ++k) at = record.find(' ', at + (k ? 1 : 0));
      if (at != std::string::npos) record.resize(at);
    }
    ++records;
    out.append(record).push_back('\n');
  }
  return out;
}

Result<Mesh> read_with_openmesh(const std::filesystem::path& path, const std::optional<std::string>& contents = std::nullopt) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  PolyMesh pm;
  pm.request_vertex_normals();
  pm.request_halfedge_normals();
  pm.request_vertex_texcoords2D();
  pm.request_halfedge_texcoords2D();
  omio::Options opt = omio::Options::VertexNormal | omio::Options::VertexTexCoord | omio::Options::FaceTexCoord;
  CheckedImporter importer(pm, ec ? std::size_t{1} << 20 : static_cast<std::size_t>(size));
  bool read_ok = false;
  {
    om::QuietStreams quiet;
    if (contents) {
      std::istringstream stream(*contents, std::ios::in | std::ios::binary);
      read_ok = omio::IOManager().read(stream, detail::lowercase_extension(path), importer, opt);
    } else {
      read_ok = omio::IOManager().read(path.string(), importer, opt);
    }
  }
  if (!read_ok) {
    return fail(ErrorKind::Parse, "'{}': OpenMesh could not read the file (corrupt, or a variant of the format it does not read)",
                path.string());
  }
  if (importer.bad_references > 0) {
    return fail(ErrorKind::Parse, "'{}': {} faces or attributes reference vertices that are not in the file (indices out of range)",
                path.string(), importer.bad_references);
  }

  if (pm.n_faces() == 0) {
    return fail(ErrorKind::InvalidArgument, "'{}': the file has {} vertices but no faces (the mesh has no triangles)",
                path.string(), pm.n_vertices());
  }

  Mesh mesh;
  mesh.name = path.stem().string();
  if (importer.repeated_vertex_faces > 0 || importer.short_faces > 0) {
    detail::warn(mesh.warnings, weft::format("'{}': skipped {} degenerate faces (a repeated vertex or fewer than 3)",
                                             path.string(), importer.repeated_vertex_faces + importer.short_faces));
  }
  if (importer.non_manifold_faces > 0) {
    detail::warn(mesh.warnings, weft::format("'{}': {} non-manifold faces (refused by OpenMesh) were kept with their "
                                             "own copies of their vertices",
                                             path.string(), importer.non_manifold_faces));
  }

  // STL has neither (and OpenMesh's STL reader leaves the requested flags set).
  const bool stl = detail::lowercase_extension(path) == ".stl";
  const bool has_normals = !stl && opt.vertex_has_normal();
  const bool corner_uvs = !stl && opt.face_has_texcoord();
  const bool vertex_uvs = !stl && !corner_uvs && opt.vertex_has_texcoord();
  // OBJ puts v = 0 at the bottom of the image; weft (like glTF and Vulkan) samples v = 0 as
  // the top row, so OBJ's v is flipped here, once. PLY and OFF have no agreed convention
  // and are read as written (docs/scene-format.md).
  const bool flip_v = detail::lowercase_extension(path) == ".obj";
  std::unordered_map<CornerKey, std::uint32_t, CornerKeyHash> split;
  split.reserve(pm.n_vertices() * 2);
  std::vector<std::uint32_t> polygon;
  for (const auto fh : pm.faces()) {
    polygon.clear();
    for (const auto heh : pm.fh_range(fh)) {
      const auto vh = pm.to_vertex_handle(heh);
      vec2 uv(0.0f);
      if (corner_uvs) {
        const auto t = pm.texcoord2D(heh);
        uv = vec2(t[0], t[1]);
      } else if (vertex_uvs) {
        const auto t = pm.texcoord2D(vh);
        uv = vec2(t[0], t[1]);
      }
      if (flip_v) uv.y = 1.0f - uv.y;
      vec3 normal(0.0f);
      if (has_normals) {
        auto nrm = pm.normal(heh);  // the corner's own normal (OBJ), else the vertex's
        if (nrm.sqrnorm() == 0.0f) nrm = pm.normal(vh);
        normal = vec3(nrm[0], nrm[1], nrm[2]);
      }
      const CornerKey key{{static_cast<std::uint32_t>(vh.idx()), std::bit_cast<std::uint32_t>(uv.x),
                           std::bit_cast<std::uint32_t>(uv.y), std::bit_cast<std::uint32_t>(normal.x),
                           std::bit_cast<std::uint32_t>(normal.y), std::bit_cast<std::uint32_t>(normal.z)}};
      auto [it, inserted] = split.try_emplace(key, static_cast<std::uint32_t>(mesh.positions.size()));
      if (inserted) {
        const auto p = pm.point(vh);
        mesh.positions.emplace_back(p[0], p[1], p[2]);
        if (has_normals) mesh.normals.push_back(normal);
        if (corner_uvs || vertex_uvs) mesh.uvs.push_back(uv);
      }
      polygon.push_back(it->second);
    }
    for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
      mesh.indices.insert(mesh.indices.end(), {polygon[0], polygon[i], polygon[i + 1]});
    }
  }
  if (stl) {
    // A triangle soup with nothing but positions: equal positions are one vertex.
    detail::Welding w = detail::weld(mesh.positions);
    for (std::uint32_t& i : mesh.indices) i = w.of[i];
    mesh.positions = std::move(w.positions);
  }
  return mesh;
}

// Every instance of every glTF mesh, moved to world space, as one mesh.
Result<Mesh> merge_gltf(const std::filesystem::path& path) {
  auto scene = detail::read_gltf(path);
  if (!scene) return std::unexpected(scene.error());
  Mesh merged;
  merged.name = path.stem().string();
  merged.warnings = scene->warnings;
  bool any_uvs = false, any_uvs1 = false, all_normals = true, all_tangents = true;
  for (const Object& inst : scene->instances) {
    const Mesh& m = scene->meshes[inst.mesh];
    any_uvs = any_uvs || m.has_uvs();
    any_uvs1 = any_uvs1 || !m.uvs1.empty();
    all_normals = all_normals && !m.normals.empty();
    all_tangents = all_tangents && !m.tangents.empty();
  }
  for (const Object& inst : scene->instances) {
    const Mesh& m = scene->meshes[inst.mesh];
    const auto base = static_cast<std::uint32_t>(merged.positions.size());
    const mat3 linear(inst.transform);
    const mat3 normal_matrix = glm::transpose(glm::inverse(linear));
    const float handedness = glm::determinant(linear) < 0.0f ? -1.0f : 1.0f;
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
      merged.positions.push_back(vec3(inst.transform * vec4(m.positions[i], 1.0f)));
      if (all_normals) merged.normals.push_back(normal_matrix * m.normals[i]);
      if (all_tangents && all_normals) {
        merged.tangents.push_back(vec4(linear * vec3(m.tangents[i]), m.tangents[i].w * handedness));
      }
      if (any_uvs) merged.uvs.push_back(m.has_uvs() ? m.uvs[i] : vec2(0.0f));
      if (any_uvs1) merged.uvs1.push_back(!m.uvs1.empty() ? m.uvs1[i] : vec2(0.0f));
    }
    // A mirroring transform turns the winding around; swap two corners to keep it.
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const std::uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
      if (handedness < 0.0f) merged.indices.insert(merged.indices.end(), {base + a, base + c, base + b});
      else merged.indices.insert(merged.indices.end(), {base + a, base + b, base + c});
    }
  }
  if (!all_normals) merged.normals.clear();
  if (!all_tangents || !all_normals) merged.tangents.clear();
  return merged;
}

}  // namespace

Result<Mesh> load_mesh(const std::filesystem::path& path, const LoadOptions& options) {
  try {
    // OpenMesh opens the path itself (OBJ, STL): a FIFO or a device must not reach it.
    if (auto ok = weft::check_input_file(path, "mesh file"); !ok) return std::unexpected(ok.error());
    const std::string ext = detail::lowercase_extension(path);
    Result<Mesh> mesh = std::unexpected(Error{});
    if (ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl") {
      std::optional<std::string> rewritten;
      if (ext == ".obj") {
        if (auto ok = detail::check_obj(path); !ok) return std::unexpected(ok.error());
      } else if (ext == ".ply") {
        auto layout = detail::check_ply(path);
        if (!layout) return std::unexpected(layout.error());
        auto faces = detail::ply_strips_as_faces(path, *layout);
        if (!faces) return std::unexpected(faces.error());
        rewritten = std::move(*faces);
      } else if (ext == ".off") {
        if (auto ok = detail::check_off(path); !ok) return std::unexpected(ok.error());
        auto canonical = canonical_off(path);
        if (!canonical) return std::unexpected(canonical.error());
        rewritten = std::move(*canonical);
      }
      mesh = read_with_openmesh(path, rewritten);
    } else if (ext == ".gltf" || ext == ".glb") {
      mesh = merge_gltf(path);
    } else {
      return fail(ErrorKind::Unsupported, "mesh file '{}': unknown extension '{}' (weft reads .obj .ply .off .stl .gltf .glb)",
                  path.string(), ext);
    }
    if (!mesh) return mesh;
    if (auto ok = detail::prepare_mesh(*mesh, options, weft::format("'{}'", path.string())); !ok) {
      return std::unexpected(ok.error());
    }
    return mesh;
  } catch (const std::bad_alloc&) {
    return fail(ErrorKind::Parse, "'{}': out of memory while reading (a corrupt element count?)", path.string());
  } catch (const std::exception& e) {
    return fail(ErrorKind::Parse, "'{}': {}", path.string(), e.what());
  } catch (...) {
    return fail(ErrorKind::Internal, "'{}': unknown exception while reading", path.string());
  }
}

}  // namespace weft::scene
