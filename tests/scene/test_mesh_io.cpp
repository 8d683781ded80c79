// weft.scene mesh files: OBJ/PLY/OFF/STL through OpenMesh (counts, positions, UV seams,
// polygons), and the error and repair paths (bad indices, NaN, degenerate and non-manifold
// faces, empty meshes, unknown formats).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "support.h"

import weft.core;
import weft.scene;

using namespace scene_test;
using weft::ErrorKind;
using weft::vec2;
using weft::vec3;
namespace sc = weft::scene;

namespace {

bool near3(vec3 a, vec3 b, float eps = 1e-5f) { return glm::length(a - b) <= eps; }

bool has_position(const sc::Mesh& m, vec3 p) {
  return std::any_of(m.positions.begin(), m.positions.end(), [&](vec3 q) { return near3(p, q); });
}

bool any_warning(const sc::Mesh& m, std::string_view part) {
  return std::any_of(m.warnings.begin(), m.warnings.end(), [&](const std::string& w) { return contains(w, part); });
}

// The basic invariants every prepared mesh keeps.
void check_prepared(const sc::Mesh& m) {
  const std::size_t n = m.vertex_count();
  REQUIRE(n > 0);
  CHECK(m.normals.size() == n);
  CHECK(m.tangents.size() == n);
  CHECK(m.curvature.size() == n);
  CHECK(m.mean_curvature.size() == n);
  CHECK(m.gaussian_curvature.size() == n);
  CHECK(m.principal_curvatures.size() == n);
  CHECK((m.uvs.empty() || m.uvs.size() == n));
  CHECK(m.indices.size() % 3 == 0);
  for (std::uint32_t i : m.indices) CHECK(i < n);
  for (std::size_t i = 0; i < n; ++i) {
    CHECK(std::abs(glm::length(m.normals[i]) - 1.0f) < 1e-4f);
    CHECK(std::abs(glm::length(vec3(m.tangents[i])) - 1.0f) < 1e-4f);
    CHECK(std::abs(glm::dot(m.normals[i], vec3(m.tangents[i]))) < 1e-4f);
    CHECK(std::abs(m.tangents[i].w) == 1.0f);
    CHECK(std::isfinite(m.curvature[i]));
    CHECK(std::isfinite(m.mean_curvature[i]));
  }
  for (const vec3& p : m.positions) {
    CHECK(p.x >= m.bounds.min.x);
    CHECK(p.x <= m.bounds.max.x);
  }
}

constexpr const char* tetra_positions[] = {"0 0 0", "1 0 0", "0 1 0", "0 0 1"};

}  // namespace

TEST_CASE("OBJ: a quad with UVs and normals loads with its counts, positions and UVs") {
  TempDir dir;
  write_file(dir / "quad.obj",
             "# a unit quad\nv 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 0\n"
             "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
             "f 1/1/1 2/2/1 3/3/1 4/4/1\n");
  auto mesh = sc::load_mesh(dir / "quad.obj");
  REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
  CHECK(mesh->name == "quad");
  CHECK(mesh->vertex_count() == 4);
  CHECK(mesh->triangle_count() == 2);  // the quad fanned into two triangles
  CHECK(mesh->has_uvs());
  CHECK(has_position(*mesh, {2, 3, 0}));
  for (std::size_t i = 0; i < 4; ++i) {
    // u = x / 2 and OBJ's v = y / 3 for this quad: the UVs travelled with their corners,
    // and v is flipped into weft's convention (v = 0 the image's top row).
    CHECK(mesh->uvs[i].x == doctest::Approx(mesh->positions[i].x / 2.0f));
    CHECK(mesh->uvs[i].y == doctest::Approx(1.0f - mesh->positions[i].y / 3.0f));
    CHECK(near3(mesh->normals[i], {0, 0, 1}));
    CHECK(near3(vec3(mesh->tangents[i]), {1, 0, 0}));  // u grows along +X
    CHECK(mesh->tangents[i].w == 1.0f);  // the bitangent points up the image: +Y
    CHECK(mesh->curvature[i] == 0.0f);  // flat
  }
  CHECK(mesh->bounds.min == vec3(0, 0, 0));
  CHECK(mesh->bounds.max == vec3(2, 3, 0));
  check_prepared(*mesh);
}

TEST_CASE("texture orientation: each format's UV corners sample the texels its authors meant") {
  // A 2x2 image stored top row first: TL, TR / BL, BR. weft samples (u, v) = (0, 0) as the
  // top-left texel, so the texel a UV names is (floor(2u), floor(2v)).
  const auto texel = [](weft::vec2 uv) {
    const int x = std::clamp(int(std::floor(uv.x * 2.0f)), 0, 1), y = std::clamp(int(std::floor(uv.y * 2.0f)), 0, 1);
    return std::string(y == 0 ? "T" : "B") + (x == 0 ? "L" : "R");
  };
  const auto texel_at = [&](const sc::Mesh& m, vec3 corner_towards) {
    // The UV a quarter of the way from the centre towards a corner: averaging the two
    // triangles' corners is not needed, the quad's UVs are affine in position.
    for (std::size_t i = 0; i < m.vertex_count(); ++i) {
      if (near3(m.positions[i], corner_towards)) {
        const weft::vec2 centre(0.5f);
        return texel(centre + (m.uvs[i] - centre) * 0.5f);
      }
    }
    return std::string("none");
  };
  TempDir dir;
  SUBCASE("OBJ: v = 0 is the image's bottom row") {
    // An upright image on a quad facing +Z: vt (0, 0) at the bottom-left corner.
    write_file(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                 "f 1/1 2/2 3/3 4/4\n");
    auto mesh = sc::load_mesh(dir / "quad.obj");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(texel_at(*mesh, {0, 0, 0}) == "BL");
    CHECK(texel_at(*mesh, {1, 0, 0}) == "BR");
    CHECK(texel_at(*mesh, {1, 1, 0}) == "TR");
    CHECK(texel_at(*mesh, {0, 1, 0}) == "TL");
    // Upright and not mirrored: the bitangent points up the image, +Y (glTF's rule).
    for (std::size_t i = 0; i < mesh->vertex_count(); ++i) {
      CHECK(near3(mesh->tangents[i].w * glm::cross(mesh->normals[i], vec3(mesh->tangents[i])), {0, 1, 0}));
    }
  }
  SUBCASE("glTF: v = 0 is the image's top row, read as written") {
    // support.h's quad: TEXCOORD_0 (0, 0) at the origin, v growing along +Y.
    write_file(dir / "quad.gltf", gltf_json());
    auto mesh = sc::load_mesh(dir / "quad.gltf");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    // Merged in world space: the child instance spans (1,2)-(3,4), u along +X, v along +Y.
    CHECK(texel_at(*mesh, {1, 2, 0}) == "TL");
    CHECK(texel_at(*mesh, {3, 2, 0}) == "TR");
    CHECK(texel_at(*mesh, {3, 4, 0}) == "BR");
    CHECK(texel_at(*mesh, {1, 4, 0}) == "BL");
  }
}

TEST_CASE("OBJ: a UV seam splits vertices, but normals and curvature stay welded") {
  TempDir dir;
  // Two quads sharing the edge 2-5, with different UVs on each side of it.
  write_file(dir / "seam.obj",
             "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n"
             "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0\nvt 0.5 1\n"
             "f 1/1 2/2 5/3 4/4\n"
             "f 2/5 3/2 6/3 5/6\n");
  auto mesh = sc::load_mesh(dir / "seam.obj");
  REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
  CHECK(mesh->vertex_count() == 8);  // 6 positions, the 2 on the seam twice
  CHECK(mesh->triangle_count() == 4);
  for (const vec3& n : mesh->normals) CHECK(near3(n, {0, 0, 1}));  // computed: no normals in the file
  check_prepared(*mesh);
}

TEST_CASE("OBJ: normals are recomputed on request and smooth across equal positions") {
  TempDir dir;
  write_file(dir / "tent.obj", "v -1 0 0\nv 0 1 0\nv 1 0 0\nv 0 1 -1\nv 0 0 -1\nvn 1 0 0\n"
                               "f 1//1 2//1 5//1\nf 2//1 3//1 5//1\n");
  auto as_given = sc::load_mesh(dir / "tent.obj");
  REQUIRE(as_given.has_value());
  for (const vec3& n : as_given->normals) CHECK(near3(n, {1, 0, 0}));  // the file's (odd) normal
  auto recomputed = sc::load_mesh(dir / "tent.obj", {.recompute_normals = true});
  REQUIRE(recomputed.has_value());
  // The ridge vertex (0,1,0) sits on both faces: its normal is their angle-weighted mean.
  for (std::size_t i = 0; i < recomputed->vertex_count(); ++i) {
    if (near3(recomputed->positions[i], {0, 1, 0})) CHECK(recomputed->normals[i].x == doctest::Approx(0.0f).epsilon(1e-5));
  }
}

TEST_CASE("OBJ: normalize_to_unit_box centres the mesh and scales its largest extent to 1") {
  TempDir dir;
  write_file(dir / "box.obj", "v 10 10 10\nv 14 10 10\nv 14 12 10\nv 10 12 11\nf 1 2 3\nf 1 3 4\n");
  auto mesh = sc::load_mesh(dir / "box.obj", {.normalize_to_unit_box = true});
  REQUIRE(mesh.has_value());
  CHECK(mesh->bounds.size().x == doctest::Approx(1.0f));
  CHECK(mesh->bounds.size().y == doctest::Approx(0.5f));
  CHECK(mesh->bounds.center().x == doctest::Approx(0.0f));
  CHECK(mesh->bounds.center().z == doctest::Approx(0.0f));
}

TEST_CASE("PLY (ASCII and binary) and OFF and STL load with their counts and positions") {
  TempDir dir;
  SUBCASE("PLY ASCII tetrahedron") {
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
    for (const char* p : tetra_positions) ply += std::string(p) + "\n";
    ply += "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    write_file(dir / "tetra.ply", ply);
    auto mesh = sc::load_mesh(dir / "tetra.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->vertex_count() == 4);
    CHECK(mesh->triangle_count() == 4);
    CHECK(has_position(*mesh, {0, 0, 1}));
    CHECK_FALSE(mesh->has_uvs());
    // Closed and convex, consistently wound: every normal points away from the centroid.
    for (std::size_t i = 0; i < 4; ++i) CHECK(glm::dot(mesh->normals[i], mesh->positions[i] - vec3(0.25f)) > 0.0f);
    for (float k : mesh->mean_curvature) CHECK(k > 0.0f);
    check_prepared(*mesh);
  }
  SUBCASE("PLY binary with UVs") {
    std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nproperty float u\nproperty float v\nelement face 1\n"
                         "property list uchar int vertex_indices\nend_header\n";
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    const float v[3][5] = {{0, 0, 0, 0, 0}, {1, 0, 0, 1, 0}, {0, 1, 0, 0, 1}};
    for (const auto& row : v) {
      for (float f : row) append(bytes, f);
    }
    append(bytes, std::uint8_t{3});
    for (std::int32_t i : {0, 1, 2}) append(bytes, i);
    write_file(dir / "tri.ply", bytes);
    auto mesh = sc::load_mesh(dir / "tri.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->vertex_count() == 3);
    CHECK(mesh->triangle_count() == 1);
    REQUIRE(mesh->has_uvs());
    for (std::size_t i = 0; i < 3; ++i) CHECK(mesh->uvs[i] == vec2(mesh->positions[i].x, mesh->positions[i].y));
  }
  SUBCASE("OFF cube of quads") {
    write_file(dir / "cube.off",
               "OFF\n8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
               "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n");
    auto mesh = sc::load_mesh(dir / "cube.off");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->vertex_count() == 8);
    CHECK(mesh->triangle_count() == 12);
    CHECK(mesh->bounds.max == vec3(1, 1, 1));
    check_prepared(*mesh);
  }
  SUBCASE("NOFF, COFF with alpha and CNOFF: every vertex number on its line, comments after them") {
    for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
             {"n.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1 # a normal\n3 0 1 2\n"},
             {"c.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0\n0 1 0 0 0 255 255\n3 0 1 2\n"},
             {"cn.off", "CNOFF\n3 1 0\n0 0 0 0 0 1 1 0 0\n1 0 0 0 0 1 0 1 0 1\n0 1 0 0 0 1 0 0 1\n3 0 1 2\n"},
             // two spaces after the keyword: OpenMesh alone never returned (fuzz_off)
             {"spaced.off", "OFF  3 1 0\n0  0 0\n1 0 0\t\n0 1 0\n\n3 0  1 2\n"},
             // a face colour after the indices (OpenMesh is given the indices only)
             {"face_colour.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\n"}}) {
      write_file(dir / name, text);
      auto mesh = sc::load_mesh(dir / name);
      REQUIRE_MESSAGE(mesh.has_value(), name, ": ", mesh.error().what());
      CHECK(mesh->vertex_count() == 3);
      CHECK(mesh->triangle_count() == 1);
    }
  }
  SUBCASE("ASCII STL: a triangle soup welded into shared vertices") {
    std::string stl = "solid t\n";
    const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto& f : faces) {
      stl += "facet normal 0 0 0\nouter loop\n";
      for (int i : f) stl += std::string("vertex ") + tetra_positions[i] + "\n";
      stl += "endloop\nendfacet\n";
    }
    stl += "endsolid t\n";
    write_file(dir / "tetra.stl", stl);
    auto mesh = sc::load_mesh(dir / "tetra.stl");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->triangle_count() == 4);
    CHECK(mesh->vertex_count() == 4);  // the soup's equal corners welded
    CHECK(mesh->warnings.empty());
    check_prepared(*mesh);
  }
}

namespace {
// A 3x3 grid of vertices (c, r, 0), index r * 3 + c, as two triangle strips of one row of
// quads each, the second after a -1 restart: 8 triangles, all facing +Z when the strips'
// alternate winding is followed.
const std::vector<std::int32_t> grid_strips = {3, 0, 4, 1, 5, 2, -1, 6, 3, 7, 4, 8, 5};

std::string strips_ply_header(std::string_view format, std::size_t strip_items, std::string_view list_type = "int") {
  return "ply\nformat " + std::string(format) + " 1.0\ncomment tristrips as igea.ply has them\nelement vertex 9\n"
         "property float x\nproperty float y\nproperty float z\nelement tristrips " + std::to_string(strip_items) +
         "\nproperty list int " + std::string(list_type) + " vertex_indices\nend_header\n";
}

template <class T>
void append_big_endian(std::vector<std::uint8_t>& bytes, T value) {
  std::uint8_t raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  for (std::size_t i = sizeof(T); i-- > 0;) bytes.push_back(raw[i]);
}

void check_grid_from_strips(const sc::Mesh& mesh) {
  CHECK(mesh.triangle_count() == 8);
  CHECK(mesh.vertex_count() == 9);
  CHECK(mesh.warnings.empty());
  double area = 0.0;
  for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
    const vec3 a = mesh.positions[mesh.indices[t]], b = mesh.positions[mesh.indices[t + 1]], c = mesh.positions[mesh.indices[t + 2]];
    const vec3 n = glm::cross(b - a, c - a);
    CHECK(n.z > 0.0f);  // every second triangle turned around: one winding for the strip
    area += 0.5 * glm::length(n);
  }
  CHECK(area == doctest::Approx(4.0));  // the 2x2 grid, covered once
  for (const vec3& n : mesh.normals) CHECK(near3(n, {0, 0, 1}));
}
}  // namespace

TEST_CASE("PLY tristrips (ASCII, binary little- and big-endian): -1 restarts a strip, winding alternates") {
  TempDir dir;
  SUBCASE("ASCII, both strips in one list") {
    std::string ply = strips_ply_header("ascii", 1);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) ply += std::to_string(c) + " " + std::to_string(r) + " 0\n";
    ply += std::to_string(grid_strips.size());
    for (std::int32_t i : grid_strips) ply += " " + std::to_string(i);
    write_file(dir / "strips.ply", ply + "\n");
    auto mesh = sc::load_mesh(dir / "strips.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    check_grid_from_strips(*mesh);
  }
  SUBCASE("ASCII, one strip per list item") {
    std::string ply = strips_ply_header("ascii", 2);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) ply += std::to_string(c) + " " + std::to_string(r) + " 0\n";
    ply += "6 3 0 4 1 5 2\n6 6 3 7 4 8 5\n";
    write_file(dir / "items.ply", ply);
    auto mesh = sc::load_mesh(dir / "items.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    check_grid_from_strips(*mesh);
  }
  SUBCASE("binary, both byte orders") for (const bool big : {false, true}) {
    CAPTURE(big);
    const std::string header = strips_ply_header(big ? "binary_big_endian" : "binary_little_endian", 1);
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    const auto put = [&](auto v) { big ? append_big_endian(bytes, v) : append(bytes, v); };
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        for (float f : {float(c), float(r), 0.0f}) put(f);
    put(std::int32_t(grid_strips.size()));
    for (std::int32_t i : grid_strips) put(i);
    write_file(dir / "binary.ply", bytes);
    auto mesh = sc::load_mesh(dir / "binary.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    check_grid_from_strips(*mesh);
  }
  SUBCASE("a strip's join (a repeated vertex) makes no triangle and no warning") {
    std::string ply = strips_ply_header("ascii", 1);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) ply += std::to_string(c) + " " + std::to_string(r) + " 0\n";
    // Row 0, then the zero-area join 2 2 6 6 into row 1, which starts at an even place so
    // it keeps its winding: four triangles with a repeated vertex, all dropped.
    ply += "14 3 0 4 1 5 2 2 6 6 3 7 4 8 5\n";
    write_file(dir / "joined.ply", ply);
    auto mesh = sc::load_mesh(dir / "joined.ply");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    check_grid_from_strips(*mesh);
  }
}

TEST_CASE("PLY tristrips: malformed strips are refused, naming the element") {
  TempDir dir;
  std::string vertices;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) vertices += std::to_string(c) + " " + std::to_string(r) + " 0\n";
  const auto refused = [&](const std::string& name, const std::string& content, ErrorKind kind, std::string_view why) {
    write_file(dir / name, content);
    auto r = sc::load_mesh(dir / name);
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == kind);
    CHECK_MESSAGE(contains(r.error().message, why), r.error().message);
    CHECK_MESSAGE(contains(r.error().message, "'tristrips'"), r.error().message);
    CHECK(contains(r.error().message, name));
  };
  SUBCASE("an index past the vertices") {
    refused("past.ply", strips_ply_header("ascii", 1) + vertices + "4 0 1 9 3\n", ErrorKind::Parse,
            "vertex index 9 (entry 2) is outside 0 to 8");
  }
  SUBCASE("a negative index other than -1") {
    refused("negative.ply", strips_ply_header("ascii", 1) + vertices + "4 0 1 -2 3\n", ErrorKind::Parse, "vertex index -2");
  }
  SUBCASE("a list longer than the file") {
    refused("long.ply", strips_ply_header("ascii", 1) + vertices + "400000 0 1 2\n", ErrorKind::Parse, "is not a list length");
  }
  SUBCASE("float indices") {
    refused("float.ply", strips_ply_header("ascii", 1, "float") + vertices + "3 0 1 2\n", ErrorKind::Parse,
            "a list of integer vertex indices");
  }
  SUBCASE("both faces and strips") {
    std::string header = strips_ply_header("ascii", 1);
    header.insert(header.find("end_header"), "element face 1\nproperty list uchar int vertex_indices\n");
    refused("both.ply", header + vertices + "3 0 1 2\n3 0 1 2\n", ErrorKind::Unsupported, "both a 'face' and a 'tristrips'");
  }
}

TEST_CASE("mesh files: errors name the file and what is wrong") {
  TempDir dir;
  SUBCASE("missing file") {
    auto r = sc::load_mesh(dir / "nothing.obj");
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::NotFound);
    CHECK(contains(r.error().message, "nothing.obj"));
  }
  SUBCASE("unknown extension") {
    write_file(dir / "mesh.xyz", "1 2 3\n");
    auto r = sc::load_mesh(dir / "mesh.xyz");
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Unsupported);
    CHECK(contains(r.error().message, ".xyz"));
  }
  SUBCASE("a face index out of range") {
    write_file(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 9//1\n");
    auto r = sc::load_mesh(dir / "bad.obj");
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Parse);
    CHECK(contains(r.error().message, "bad.obj"));
    CHECK(contains(r.error().message, "out of range"));
  }
  SUBCASE("vertices but no faces") {
    write_file(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    auto r = sc::load_mesh(dir / "points.obj");
    REQUIRE_FALSE(r.has_value());
    CHECK(contains(r.error().message, "points.obj"));
    CHECK(contains(r.error().message, "no triangles"));
  }
  SUBCASE("an empty file") {
    write_file(dir / "empty.off", "");
    auto r = sc::load_mesh(dir / "empty.off");
    REQUIRE_FALSE(r.has_value());
    CHECK(contains(r.error().message, "empty.off"));
  }
  SUBCASE("a folder") {
    std::filesystem::create_directories(dir / "folder.obj");
    auto r = sc::load_mesh(dir / "folder.obj");
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Io);
  }
  SUBCASE("NaN in a binary PLY: the error names the vertex") {
    std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (float f : {0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, nan, 0.0f}) append(bytes, f);
    append(bytes, std::uint8_t{3});
    for (std::int32_t i : {0, 1, 2}) append(bytes, i);
    write_file(dir / "nan.ply", bytes);
    auto r = sc::load_mesh(dir / "nan.ply");
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Parse);
    CHECK(contains(r.error().message, "nan.ply"));
    CHECK(contains(r.error().message, "vertex 2"));
  }
}

TEST_CASE("mesh files: degenerate and non-manifold faces are repaired with a warning") {
  TempDir dir;
  SUBCASE("a face with a repeated vertex and a zero-area face") {
    write_file(dir / "degenerate.off",
               "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n2 0 0\n"
               "3 0 1 2\n"    // good
               "3 0 0 1\n"    // repeated vertex: skipped when read
               "3 1 0 3\n");  // colinear: zero area, removed by repair
    auto mesh = sc::load_mesh(dir / "degenerate.off");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->triangle_count() == 1);
    CHECK(any_warning(*mesh, "skipped 1 degenerate"));
    CHECK(any_warning(*mesh, "removed 1 degenerate"));
    CHECK_FALSE(any_warning(*mesh, "non-manifold"));
  }
  SUBCASE("a face wound against its neighbour is non-manifold to OpenMesh") {
    // Both faces run 1->2: OpenMesh refuses the second and it is kept on copied vertices.
    write_file(dir / "flipped.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n"
                                    "f 1/1 2/2 3/3\nf 1/1 2/2 4/4\n");
    auto mesh = sc::load_mesh(dir / "flipped.obj");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->triangle_count() == 2);
    CHECK(mesh->vertex_count() == 6);  // the second face on its own three copies
    CHECK(any_warning(*mesh, "non-manifold"));
    // The copies kept their UVs: (0,-1,0) carries UV (1,1), no garbage.
    for (std::size_t i = 0; i < mesh->vertex_count(); ++i) {
      CHECK(std::isfinite(mesh->uvs[i].x));
      if (near3(mesh->positions[i], {0, -1, 0})) CHECK(mesh->uvs[i] == vec2(1, 0));  // OBJ's (1, 1), v flipped
    }
  }
  SUBCASE("three faces on one edge") {
    write_file(dir / "fin.obj",
               "v 0 0 0\nv 1 0 0\nv 0.5 1 0\nv 0.5 -1 0\nv 0.5 0 1\n"
               "f 1 2 3\nf 2 1 4\nf 1 2 5\n");
    auto mesh = sc::load_mesh(dir / "fin.obj");
    REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
    CHECK(mesh->triangle_count() == 3);  // kept for drawing
    CHECK(any_warning(*mesh, "non-manifold"));
    check_prepared(*mesh);
  }
}

TEST_CASE("prepare_mesh: validation of meshes built in code") {
  sc::Mesh m;
  m.name = "code";
  SUBCASE("empty") {
    auto r = sc::prepare_mesh(m);
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::InvalidArgument);
    CHECK(contains(r.error().message, "'code'"));
    CHECK(contains(r.error().message, "no vertices"));
  }
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 2, 0}};
  SUBCASE("index out of range") {
    m.indices = {0, 1, 10};
    auto r = sc::prepare_mesh(m);
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Parse);
    CHECK(contains(r.error().message, "vertex 10"));
  }
  SUBCASE("indices not a multiple of 3") {
    m.indices = {0, 1, 2, 3};
    CHECK_FALSE(sc::prepare_mesh(m).has_value());
  }
  SUBCASE("NaN and infinite positions name the vertex") {
    m.indices = {0, 1, 2};
    m.positions[3].z = std::numeric_limits<float>::infinity();
    auto r = sc::prepare_mesh(m);
    REQUIRE_FALSE(r.has_value());
    CHECK(contains(r.error().message, "vertex 3"));
  }
  SUBCASE("per-vertex arrays of the wrong size") {
    m.indices = {0, 1, 2};
    m.uvs = {{0, 0}};
    auto r = sc::prepare_mesh(m);
    REQUIRE_FALSE(r.has_value());
    CHECK(contains(r.error().message, "UVs"));
  }
  SUBCASE("degenerate triangles are removed, with their count") {
    m.indices = {0, 1, 2,  1, 3, 2,  0, 0, 1,  0, 3, 4};  // the last is colinear (0,0)-(1,1)-(2,2)
    auto r = sc::prepare_mesh(m);
    REQUIRE(r.has_value());
    CHECK(m.triangle_count() == 2);
    CHECK(any_warning(m, "removed 2 degenerate"));
    check_prepared(m);
  }
  SUBCASE("only degenerate triangles is an error") {
    m.indices = {0, 0, 1, 0, 3, 4};
    auto r = sc::prepare_mesh(m);
    REQUIRE_FALSE(r.has_value());
    CHECK(contains(r.error().message, "degenerate"));
  }
  SUBCASE("NaN normals are recomputed with a warning") {
    m.indices = {0, 1, 2};
    m.normals.assign(5, vec3(0, 0, 1));
    m.normals[1] = vec3(std::nanf(""));
    REQUIRE(sc::prepare_mesh(m).has_value());
    CHECK(any_warning(m, "normals recomputed"));
    CHECK(near3(m.normals[1], {0, 0, 1}));
  }
  SUBCASE("an isolated vertex gets a unit normal and zero curvature") {
    m.indices = {0, 1, 2};
    REQUIRE(sc::prepare_mesh(m).has_value());
    CHECK(glm::length(m.normals[4]) == doctest::Approx(1.0f));
    CHECK(m.curvature[4] == 0.0f);
  }
}

TEST_CASE("mesh files: inputs that hang, exhaust or abort OpenMesh's readers are refused first") {
  TempDir dir;
  const std::string ply_header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const auto refused = [&](const std::string& name, const auto& content, std::string_view why) {
    write_file(dir / name, content);
    auto r = sc::load_mesh(dir / name);
    REQUIRE_FALSE(r.has_value());
    CHECK(r.error().kind == ErrorKind::Parse);
    CHECK_MESSAGE(contains(r.error().message, why), r.error().message);
    CHECK(contains(r.error().message, name));
  };
  SUBCASE("a PLY header that ends early (OpenMesh loops forever)") {
    refused("short.ply", ply_header.substr(0, 40), "no end_header");
  }
  SUBCASE("a PLY header with an unknown keyword") {
    refused("keyword.ply", "ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n", "unknown keyword");
  }
  SUBCASE("a negative ASCII list length (OpenMesh allocates 4 billion entries)") {
    refused("list.ply", ply_header + "0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n", "not a list length");
  }
  SUBCASE("a binary list length beyond the file") {
    std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    for (int i = 0; i < 9; ++i) append(bytes, float(i % 2));
    append(bytes, std::uint32_t{0xfffffffd});
    refused("list_binary.ply", bytes, "list length");
  }
  SUBCASE("a PLY body that ends early") {
    refused("body.ply", ply_header + "0 0 0\n1 0 0\n0 1", "ends");
  }
  SUBCASE("an OFF file that ends after its keyword (OpenMesh reads garbage counts)") {
    refused("keyword.off", "OFF\n", "vertex count");
  }
  SUBCASE("an empty OFF whose counts share the keyword's line (OpenMesh never returns; fuzz_off)") {
    refused("empty_same_line.off", "OFF 0 0 0\n", "the mesh is empty: 0 vertices, 0 faces");
    refused("empty_fuzzed.off", "OFF 0 0  1 2 (2\n", "the mesh is empty");
    refused("no_faces.off", "OFF\n1 0 0\n0 0 0\n", "the mesh is empty: 1 vertices, 0 faces");
  }
  SUBCASE("an OFF vertex line shorter than its keyword says (OpenMesh reads on into the next line)") {
    refused("short_cnoff.off", "CNOFF\n3 1 0\n0 0 0\n1 0 0 0 0 1 1 1 1\n0 1 0 0 0 1 1 1 1\n3 0 1 2\n",
            "a CNOFF vertex is 9 numbers (or one more: the colour's alpha), this line has 3");
    refused("long_off.off", "OFF\n3 1 0\n0 0 0 7\n1 0 0\n0 1 0\n3 0 1 2\n", "a OFF vertex is 3 numbers, this line has 4");
  }
  SUBCASE("an OFF face of fewer than 3 corners (OpenMesh looped on one with junk after it; fuzz_off)") {
    refused("one_corner.off", "OFF\n1 1 0\n0 0 0\n1 0 4888888\n", "a face of 1 corners (a face needs 3 or more)");
  }
  SUBCASE("OFF counts spread over two lines (OpenMesh reads other numbers as counts and never returns)") {
    refused("split_counts.off", "OFF 3\n1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "must stand on one line");
  }
  SUBCASE("an OFF face whose index runs into the next face's count") {
    refused("run_on.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2-3 0 2 1\n3 0 1 2\n", "not a vertex index");
  }
  SUBCASE("an OFF face with too few indices") {
    refused("few.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "fewer indices");
  }
  SUBCASE("an OBJ face corner without a vertex index (OpenMesh asserts)") {
    refused("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf /1 2/1 3/1\n", "bad face corner '/1'");
  }
}
