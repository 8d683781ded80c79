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
    // u = x / 2 and v = y / 3 for this quad: the UVs travelled with their corners.
    CHECK(mesh->uvs[i].x == doctest::Approx(mesh->positions[i].x / 2.0f));
    CHECK(mesh->uvs[i].y == doctest::Approx(mesh->positions[i].y / 3.0f));
    CHECK(near3(mesh->normals[i], {0, 0, 1}));
    CHECK(near3(vec3(mesh->tangents[i]), {1, 0, 0}));  // u grows along +X
    CHECK(mesh->tangents[i].w == 1.0f);
    CHECK(mesh->curvature[i] == 0.0f);  // flat
  }
  CHECK(mesh->bounds.min == vec3(0, 0, 0));
  CHECK(mesh->bounds.max == vec3(2, 3, 0));
  check_prepared(*mesh);
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
      if (near3(mesh->positions[i], {0, -1, 0})) CHECK(mesh->uvs[i] == vec2(1, 1));
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
