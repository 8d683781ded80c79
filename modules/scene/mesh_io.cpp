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
#include <charconv>
#include <cstdint>
#include <cstring>
#include <exception>
#include <expected>
#include <filesystem>
#include <new>
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

// OpenMesh's PLY reader loops forever on a header that ends early or is malformed, so the
// header is checked against the PLY grammar first: magic, format, then comment/obj_info,
// element and property lines up to end_header.
Result<void> check_ply_header(const std::filesystem::path& path) {
  auto bytes = detail::read_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), std::min<std::size_t>(bytes->size(), 1 << 16));
  const auto bad = [&](std::size_t line, std::string_view why) -> Result<void> {
    return fail(ErrorKind::Parse, "'{}': PLY header line {}: {}", path.string(), line, why);
  };
  static constexpr std::string_view types[] = {"char",  "uchar",  "short",   "ushort",  "int",     "uint",
                                               "float", "double", "int8",    "uint8",   "int16",   "uint16",
                                               "int32", "uint32", "float32", "float64"};
  const auto is_type = [&](std::string_view t) { return std::find(std::begin(types), std::end(types), t) != std::end(types); };
  std::size_t pos = 0, line_number = 0;
  bool have_element = false;
  while (true) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) return bad(line_number + 1, "the header has no end_header line");
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    std::vector<std::string_view> words;
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && line[i] == ' ') ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ') ++j;
      if (j > i) words.push_back(line.substr(i, j - i));
      i = j;
    }
    for (char c : line) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return bad(line_number, "control character in the header");
    }
    if (line_number == 1) {
      if (line != "ply") return bad(1, "not a PLY file (no 'ply' magic)");
      continue;
    }
    if (line_number == 2) {
      if (words.size() != 3 || words[0] != "format" ||
          (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian") ||
          words[2] != "1.0") {
        return bad(2, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      }
      continue;
    }
    if (words.empty()) return bad(line_number, "empty line");
    if (words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "end_header") {
      if (words.size() != 1) return bad(line_number, "text after end_header");
      if (!have_element) return bad(line_number, "no element declared");
      return {};
    }
    if (words[0] == "element") {
      if (words.size() != 3 || words[2].empty() || words[2].size() > 10 ||
          !std::all_of(words[2].begin(), words[2].end(), [](char c) { return c >= '0' && c <= '9'; })) {
        return bad(line_number, "expected 'element <name> <count>'");
      }
      if (std::stoull(std::string(words[2])) > bytes->size()) {
        return bad(line_number, "the element count is larger than the file could hold");
      }
      have_element = true;
      continue;
    }
    if (words[0] == "property") {
      if (!have_element) return bad(line_number, "a property before any element");
      const bool scalar = words.size() == 3 && is_type(words[1]);
      const bool list = words.size() == 5 && words[1] == "list" && is_type(words[2]) && is_type(words[3]);
      if (!scalar && !list) return bad(line_number, "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      continue;
    }
    return bad(line_number, "unknown keyword");
  }
}

// Debian's OpenMesh is built with assertions, and its OBJ reader asserts (aborting the
// process) on a face corner without a vertex index ("f /1/1 ..."); every face line is
// checked first: each corner is v, v/vt, v//vn or v/vt/vn with integer indices.
Result<void> check_obj_faces(const std::filesystem::path& path) {
  auto bytes = detail::read_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  // An optionally negative integer of 1 to 9 digits.
  const auto is_index = [](std::string_view t) {
    if (!t.empty() && t.front() == '-') t.remove_prefix(1);
    return !t.empty() && t.size() <= 9 && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  std::size_t pos = 0, line_number = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    std::size_t i = 0;
    while (i < line.size() && is_space(line[i])) ++i;
    if (i + 1 >= line.size() || line[i] != 'f' || !is_space(line[i + 1])) continue;
    for (i += 1; i < line.size();) {
      while (i < line.size() && is_space(line[i])) ++i;
      std::size_t j = i;
      while (j < line.size() && !is_space(line[j])) ++j;
      if (j == i) break;
      const std::string_view corner = line.substr(i, j - i);
      i = j;
      const std::size_t a = corner.find('/');
      const std::size_t b = a == std::string_view::npos ? a : corner.find('/', a + 1);
      bool ok = is_index(corner.substr(0, a));
      if (ok && a != std::string_view::npos) {
        const std::string_view vt = corner.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1);
        ok = vt.empty() ? b != std::string_view::npos : is_index(vt);
        if (ok && b != std::string_view::npos) ok = is_index(corner.substr(b + 1));
      }
      if (!ok) {
        return fail(ErrorKind::Parse, "'{}': line {}: bad face corner '{}' (expected v, v/vt, v//vn or v/vt/vn)",
                    path.string(), line_number, corner.substr(0, 40));
      }
    }
  }
  return {};
}

// OpenMesh's OFF reader trusts the counts line (and reads garbage counts from a file that
// ends before it), looping billions of times; the file is checked first: the OFF keyword
// with its optional prefixes, counts the file could hold, then the vertex and face lines.
Result<void> check_off(const std::filesystem::path& path) {
  auto bytes = detail::read_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  const auto bad = [&](std::string_view why) -> Result<void> {
    return fail(ErrorKind::Parse, "'{}': OFF header: {}", path.string(), why);
  };
  std::size_t pos = 0;
  // The next whitespace-separated word, skipping '#' comments.
  const auto next_word = [&]() -> std::string_view {
    while (pos < text.size()) {
      const char c = text[pos];
      if (c == '#') {
        while (pos < text.size() && text[pos] != '\n') ++pos;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
        ++pos;
      } else {
        break;
      }
    }
    const std::size_t start = pos;
    while (pos < text.size() && text[pos] != ' ' && text[pos] != '\t' && text[pos] != '\r' && text[pos] != '\n') ++pos;
    return text.substr(start, pos - start);
  };
  std::string_view keyword = next_word();
  if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF") return bad("the file does not start with OFF");
  std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  if (prefix.starts_with("ST")) prefix.remove_prefix(2);
  for (char flag : {'C', 'N', '4', 'n'}) {
    if (!prefix.empty() && prefix.front() == flag) prefix.remove_prefix(1);
  }
  if (!prefix.empty()) return bad(fmt::format("unknown keyword '{}'", keyword));
  const std::size_t line_end = text.find('\n', pos);
  const bool binary = text.substr(pos, line_end == std::string_view::npos ? text.size() - pos : line_end - pos).find("BINARY") !=
                      std::string_view::npos;
  if (binary) return bad("binary OFF is not read by weft");
  if (keyword.find('n') != std::string_view::npos) (void)next_word();  // the dimension of nOFF
  std::size_t counts[3] = {0, 0, 0};
  int c = 0;
  for (const char* what : {"vertex", "face", "edge"}) {
    const std::string_view word = next_word();
    if (word.empty() || word.size() > 10 || !std::all_of(word.begin(), word.end(), [](char ch) { return ch >= '0' && ch <= '9'; })) {
      return bad(fmt::format("expected the {} count, got '{}'", what, word.substr(0, 20)));
    }
    counts[c] = std::stoull(std::string(word));
    if (counts[c++] > bytes->size()) return bad(fmt::format("the {} count is larger than the file could hold", what));
  }

  // The body, line by line: OpenMesh reads it token by token and trusts every count in it
  // (a face "6-4" makes the next face's corner count -4, read four billion times).
  const auto fail_at = [&](std::size_t line, std::string_view why) -> Result<void> {
    return fail(ErrorKind::Parse, "'{}': OFF line {}: {}", path.string(), line, why);
  };
  std::size_t line_number = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + std::ptrdiff_t(pos), '\n'));
  const std::size_t first_line_end = text.find('\n', pos);
  pos = first_line_end == std::string_view::npos ? text.size() : first_line_end + 1;
  std::size_t vertices_seen = 0, faces_seen = 0;
  std::vector<std::string_view> tokens;
  while (faces_seen < counts[1] || vertices_seen < counts[0]) {
    if (pos >= text.size()) {
      return fail_at(line_number + 1, vertices_seen < counts[0]
                                          ? fmt::format("the file ends after {} of {} vertices", vertices_seen, counts[0])
                                          : fmt::format("the file ends after {} of {} faces", faces_seen, counts[1]));
    }
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    tokens.clear();
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      if (j > i) tokens.push_back(line.substr(i, j - i));
      i = j;
    }
    if (tokens.empty() || tokens[0].front() == '#') continue;
    if (vertices_seen < counts[0]) {
      if (tokens.size() < 3) return fail_at(line_number, "a vertex needs 3 coordinates");
      for (std::size_t k = 0; k < 3; ++k) {
        float value = 0.0f;
        const auto [ptr, ec] = std::from_chars(tokens[k].data(), tokens[k].data() + tokens[k].size(), value);
        if (ec != std::errc() || ptr != tokens[k].data() + tokens[k].size()) {
          return fail_at(line_number, fmt::format("'{}' is not a number", tokens[k].substr(0, 20)));
        }
      }
      ++vertices_seen;
      continue;
    }
    const auto integer = [](std::string_view t, long long& out) {
      const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
      return ec == std::errc() && ptr == t.data() + t.size();
    };
    long long corners = 0;
    if (!integer(tokens[0], corners) || corners < 1 || corners > 4096) {
      return fail_at(line_number, fmt::format("'{}' is not a face's corner count", tokens[0].substr(0, 20)));
    }
    if (tokens.size() < std::size_t(corners) + 1) return fail_at(line_number, "the face has fewer indices than its count");
    for (long long k = 1; k <= corners; ++k) {
      long long index = 0;
      if (!integer(tokens[std::size_t(k)], index) || index < 0 || std::size_t(index) >= counts[0]) {
        return fail_at(line_number, fmt::format("'{}' is not a vertex index below {}", tokens[std::size_t(k)].substr(0, 20), counts[0]));
      }
    }
    ++faces_seen;
  }
  return {};
}

Result<Mesh> read_with_openmesh(const std::filesystem::path& path) {
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
    read_ok = omio::IOManager().read(path.string(), importer, opt);
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
  bool any_uvs = false, all_normals = true, all_tangents = true;
  for (const Object& inst : scene->instances) {
    const Mesh& m = scene->meshes[inst.mesh];
    any_uvs = any_uvs || m.has_uvs();
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
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return fail(ErrorKind::NotFound, "mesh file '{}' not found", path.string());
    if (std::filesystem::is_directory(path, ec)) {
      return fail(ErrorKind::Io, "mesh file '{}' is a folder, not a file", path.string());
    }
    const std::string ext = detail::lowercase_extension(path);
    Result<Mesh> mesh = std::unexpected(Error{});
    if (ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl") {
      if (ext == ".obj") {
        if (auto ok = check_obj_faces(path); !ok) return std::unexpected(ok.error());
      } else if (ext == ".ply") {
        if (auto ok = check_ply_header(path); !ok) return std::unexpected(ok.error());
      } else if (ext == ".off") {
        if (auto ok = check_off(path); !ok) return std::unexpected(ok.error());
      }
      mesh = read_with_openmesh(path);
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
