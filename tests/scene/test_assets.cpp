// The real assets (../shared/data, when WEFT_SHARED_DATA points at it) and the shipped
// default scene. Expected counts are computed from the OBJ text itself, so the test states
// what weft does with a file: OpenMesh keeps every position, weft splits a position into as
// many GPU vertices as it has distinct UVs (the seams), and fans polygons into triangles.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <glm/glm.hpp>

#include "support.h"

import weft.core;
import weft.scene;

using namespace scene_test;
using weft::vec3;
namespace sc = weft::scene;

namespace {

struct ObjCounts {
  std::size_t v_lines = 0;
  std::size_t distinct_positions = 0;     // among the positions faces use
  std::size_t distinct_corners = 0;       // (position, UV value) pairs faces use
  std::size_t triangles = 0;              // polygons fanned
};

// A small reader for the "f v/vt" OBJs of the shared data (no normals in them).
ObjCounts count_obj(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::array<float, 3>> v;
  std::vector<std::array<float, 2>> vt;
  std::set<std::array<float, 3>> positions;
  std::set<std::tuple<float, float, float, float, float>> corners;
  ObjCounts c;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      std::array<float, 3> p{};
      s >> p[0] >> p[1] >> p[2];
      v.push_back(p);
      ++c.v_lines;
    } else if (tag == "vt") {
      std::array<float, 2> t{};
      s >> t[0] >> t[1];
      vt.push_back(t);
    } else if (tag == "f") {
      std::size_t n = 0;
      for (std::string corner; s >> corner; ++n) {
        const std::size_t slash = corner.find('/');
        const long vi = std::stol(corner.substr(0, slash)) - 1;
        std::array<float, 2> uv{0, 0};
        if (slash != std::string::npos && slash + 1 < corner.size() && corner[slash + 1] != '/') {
          uv = vt[std::size_t(std::stol(corner.substr(slash + 1)) - 1)];
        }
        const auto& p = v[std::size_t(vi)];
        positions.insert(p);
        corners.emplace(p[0], p[1], p[2], uv[0], uv[1]);
      }
      if (n >= 3) c.triangles += n - 2;
    }
  }
  c.distinct_positions = positions.size();
  c.distinct_corners = corners.size();
  return c;
}

std::size_t distinct(const std::vector<vec3>& positions) {
  std::set<std::array<float, 3>> s;
  for (const vec3& p : positions) s.insert({p.x + 0.0f, p.y + 0.0f, p.z + 0.0f});
  return s.size();
}

void check_real_mesh(const std::filesystem::path& path, std::size_t documented_vertices) {
  INFO(path.string());
  const ObjCounts expected = count_obj(path);
  CHECK(expected.v_lines == documented_vertices);  // the data README's count
  auto mesh = sc::load_mesh(path);
  REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
  CHECK(mesh->vertex_count() == expected.distinct_corners);
  CHECK(distinct(mesh->positions) == expected.distinct_positions);
  CHECK(mesh->triangle_count() + 0 <= expected.triangles);  // minus any degenerate ones removed
  CHECK(mesh->triangle_count() + 16 >= expected.triangles);
  CHECK(mesh->has_uvs());
  std::size_t finite = 0;
  double outward = 0.0;
  const vec3 centre = mesh->bounds.center();
  for (std::size_t i = 0; i < mesh->vertex_count(); ++i) {
    finite += std::isfinite(mesh->curvature[i]) && std::isfinite(mesh->mean_curvature[i]) &&
              std::isfinite(mesh->gaussian_curvature[i]) && std::isfinite(mesh->principal_curvatures[i].x) &&
              std::isfinite(mesh->principal_curvatures[i].y) && mesh->curvature[i] >= 0.0f;
    outward += glm::dot(mesh->normals[i], mesh->positions[i] - centre);
    CHECK(std::abs(glm::dot(mesh->normals[i], vec3(mesh->tangents[i]))) < 1e-4f);
  }
  CHECK(finite == mesh->vertex_count());
  CHECK(outward > 0.0);  // consistently wound, normals face out
  MESSAGE(path.filename().string(), ": ", expected.v_lines, " positions in the file, ", mesh->vertex_count(),
          " vertices after UV-seam splits, ", mesh->triangle_count(), " triangles, ", mesh->warnings.size(), " warnings");
}

}  // namespace

TEST_CASE("real assets: spot, teapot and head load with the file's counts and finite curvature") {
  const auto data = shared_data();
  if (!data) {
    MESSAGE("skipped: WEFT_SHARED_DATA (../shared/data with meshes/spot, teapot, head) is not there");
    return;
  }
  // Spot: 2,930 positions (the README); 5,856 triangles; UV seams split some positions.
  check_real_mesh(*data / "meshes" / "spot" / "spot_triangulated.obj", 2930);
  check_real_mesh(*data / "meshes" / "teapot" / "teapot.obj", 7850);
  check_real_mesh(*data / "meshes" / "head" / "head.obj", 8844);
  auto spot = sc::load_mesh(*data / "meshes" / "spot" / "spot_triangulated.obj");
  REQUIRE(spot.has_value());
  CHECK(spot->triangle_count() == 5856);
  CHECK(spot->warnings.empty());  // manifold, no degenerate faces

  auto env = sc::load_environment(*data / "env" / "royal_esplanade_1k.hdr");
  REQUIRE_MESSAGE(env.has_value(), env.error().what());
  CHECK(env->map->width == 1024);
  CHECK(env->map->height == 512);
  CHECK(env->radiance({0, 1, 0}).x > 0.0f);  // a daylight sky is bright overhead
}

TEST_CASE("the shipped default scene parses and loads (standard materials only)") {
  const auto root = source_dir();
  if (!root) {
    MESSAGE("skipped: WEFT_SOURCE_DIR is not set");
    return;
  }
  auto scene = sc::load_scene(*root / "examples" / "scenes" / "default.json");
  REQUIRE_MESSAGE(scene.has_value(), scene.error().what());
  CHECK(scene->objects.size() == 4);
  CHECK(scene->uses(sc::standard_material));
  CHECK_FALSE(scene->uses("shell_fur"));
  CHECK_FALSE(scene->uses("skin_sss"));
  CHECK_FALSE(scene->uses("neural_btf"));
  REQUIRE(scene->environment.map.has_value());
  CHECK(scene->environment.map->width == 1024);
  CHECK(sc::validate(scene->camera).has_value());
  CHECK(scene->warnings.empty());
  // Spot stands on the floor: its lowest point at y = 0 within a millimetre.
  for (const sc::Object& o : scene->objects) {
    if (o.name != "spot") continue;
    const sc::Bounds b = scene->meshes[o.mesh].bounds.transformed(o.transform);
    CHECK(std::abs(b.min.y) < 2e-3f);
    CHECK(!scene->materials[o.material].standard.base_color_texture.empty());
  }
}
