// weft.scene processing against analytic answers: primitives' normals and tangents, skin,
// mean, Gaussian and principal curvature on a sphere, a plane and a torus; the camera's
// Vulkan projection; the environment's equirectangular mapping.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "support.h"

import weft.core;
import weft.image;
import weft.scene;

using namespace scene_test;
using weft::mat4;
using weft::vec2;
using weft::vec3;
using weft::vec4;
namespace sc = weft::scene;

namespace {

bool near3(vec3 a, vec3 b, float eps = 1e-5f) { return glm::length(a - b) <= eps; }

void check_frames(const sc::Mesh& m) {
  REQUIRE(m.tangents.size() == m.vertex_count());
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    const vec3 t(m.tangents[i]);
    CHECK(std::abs(glm::length(m.normals[i]) - 1.0f) < 1e-5f);
    CHECK(std::abs(glm::length(t) - 1.0f) < 1e-5f);
    CHECK(std::abs(glm::dot(t, m.normals[i])) < 1e-5f);
    CHECK(std::abs(m.tangents[i].w) == 1.0f);
  }
}

struct Stats {
  double min = 1e30, max = -1e30, mean = 0;
};
template <class F>
Stats stats(std::size_t n, F f) {
  Stats s;
  for (std::size_t i = 0; i < n; ++i) {
    const double v = f(i);
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
    s.mean += v / double(n);
  }
  return s;
}

}  // namespace

TEST_CASE("sphere: recomputed normals are radial; curvatures are 1/r and 1/r^2") {
  const float r = 2.0f;
  auto sphere = sc::make_sphere(r, 64);
  REQUIRE(sphere.has_value());
  CHECK(sphere->triangle_count() == 64 * 32 * 2 - 2 * 64);  // the pole rows are single triangles
  check_frames(*sphere);
  CHECK(sphere->bounds.max.y == doctest::Approx(r));

  sphere->normals.clear();
  sc::compute_normals(*sphere);
  for (std::size_t i = 0; i < sphere->vertex_count(); ++i) {
    CHECK(glm::dot(sphere->normals[i], glm::normalize(sphere->positions[i])) > 0.9995f);
  }
  sc::compute_curvature(*sphere);
  const std::size_t n = sphere->vertex_count();
  const Stats skin = stats(n, [&](std::size_t i) { return sphere->curvature[i]; });
  const Stats mean = stats(n, [&](std::size_t i) { return sphere->mean_curvature[i]; });
  const Stats gauss = stats(n, [&](std::size_t i) { return sphere->gaussian_curvature[i]; });
  // Every vertex, poles included, within 3% of 1/r = 0.5.
  CHECK(skin.min > 0.5 * 0.97);
  CHECK(skin.max < 0.5 * 1.03);
  CHECK(mean.min > 0.5 * 0.97);
  CHECK(mean.max < 0.5 * 1.03);
  CHECK(gauss.min > 0.25 * 0.99);
  CHECK(gauss.max < 0.25 * 1.01);
  for (std::size_t i = 0; i < n; ++i) {
    CHECK(sphere->principal_curvatures[i].x >= sphere->principal_curvatures[i].y);
    CHECK(sphere->principal_curvatures[i].x == doctest::Approx(0.5).epsilon(0.1));
  }
}

TEST_CASE("sphere: curvature scales as 1/r and is positive for outward normals") {
  for (float r : {0.01f, 1.0f, 100.0f}) {
    auto s = sc::make_sphere(r, 32);
    REQUIRE(s.has_value());
    const Stats skin = stats(s->vertex_count(), [&](std::size_t i) { return s->curvature[i] * r; });
    const Stats mean = stats(s->vertex_count(), [&](std::size_t i) { return s->mean_curvature[i] * r; });
    CHECK(skin.mean == doctest::Approx(1.0).epsilon(0.02));
    CHECK(mean.mean == doctest::Approx(1.0).epsilon(0.02));
  }
}

TEST_CASE("plane: zero curvature everywhere, +Y normals, tangents along +X") {
  auto plane = sc::make_plane(3.0f, 8);
  REQUIRE(plane.has_value());
  CHECK(plane->vertex_count() == 81);
  CHECK(plane->triangle_count() == 128);
  check_frames(*plane);
  for (std::size_t i = 0; i < plane->vertex_count(); ++i) {
    CHECK(near3(plane->normals[i], {0, 1, 0}));
    CHECK(near3(vec3(plane->tangents[i]), {1, 0, 0}));
    CHECK(plane->curvature[i] == 0.0f);
    CHECK(std::abs(plane->mean_curvature[i]) < 1e-6f);
    CHECK(std::abs(plane->gaussian_curvature[i]) < 1e-6f);
  }
  // Counter-clockwise seen from +Y.
  const auto& p = plane->positions;
  const auto& ix = plane->indices;
  CHECK(glm::cross(p[ix[1]] - p[ix[0]], p[ix[2]] - p[ix[0]]).y > 0.0f);
  CHECK(plane->bounds.size().x == doctest::Approx(3.0f));
}

TEST_CASE("torus: Gaussian curvature positive outside, negative inside; mean curvature analytic") {
  const float R = 1.0f, r = 0.25f;
  auto torus = sc::make_torus(R, r, 128, 64);
  REQUIRE(torus.has_value());
  check_frames(*torus);
  for (std::size_t i = 0; i < torus->vertex_count(); ++i) {
    const vec3 p = torus->positions[i];
    const float ring = std::sqrt(p.x * p.x + p.z * p.z);
    if (std::abs(p.y) > 1e-4f) continue;  // the equators only
    if (ring > R) {  // outer: k1 = 1/r, k2 = 1/(R + r)
      CHECK(torus->gaussian_curvature[i] == doctest::Approx(1.0 / (r * (R + r))).epsilon(0.05));
      CHECK(torus->mean_curvature[i] == doctest::Approx(0.5 * (1.0 / r + 1.0 / (R + r))).epsilon(0.03));
    } else {  // inner: k2 = -1/(R - r)
      CHECK(torus->gaussian_curvature[i] == doctest::Approx(-1.0 / (r * (R - r))).epsilon(0.05));
      CHECK(torus->mean_curvature[i] == doctest::Approx(0.5 * (1.0 / r - 1.0 / (R - r))).epsilon(0.03));
      CHECK(torus->principal_curvatures[i].y < 0.0f);
    }
  }
}

TEST_CASE("cube: hard edges keep face normals; tangents unit and orthogonal") {
  auto cube = sc::make_cube(2.0f);
  REQUIRE(cube.has_value());
  CHECK(cube->vertex_count() == 24);
  CHECK(cube->triangle_count() == 12);
  check_frames(*cube);
  CHECK(cube->bounds.min == vec3(-1.0f));
  CHECK(cube->bounds.max == vec3(1.0f));
  for (std::size_t t = 0; t < cube->indices.size(); t += 3) {  // outward winding
    const vec3 a = cube->positions[cube->indices[t]], b = cube->positions[cube->indices[t + 1]],
               c = cube->positions[cube->indices[t + 2]];
    CHECK(glm::dot(glm::cross(b - a, c - a), (a + b + c) / 3.0f) > 0.0f);
  }
  // The cube's curvature lives at its edges and corners; it is finite and non-negative.
  for (float k : cube->curvature) CHECK((std::isfinite(k) && k >= 0.0f));
}

TEST_CASE("primitives refuse bad arguments") {
  CHECK_FALSE(sc::make_sphere(0.0f).has_value());
  CHECK_FALSE(sc::make_sphere(std::nanf("")).has_value());
  CHECK_FALSE(sc::make_plane(-1.0f).has_value());
  CHECK_FALSE(sc::make_torus(1.0f, 2.0f).has_value());
  CHECK_FALSE(sc::make_cube(std::numeric_limits<float>::infinity()).has_value());
  auto tiny = sc::make_sphere(1.0f, 0);  // clamped to 3 segments
  REQUIRE(tiny.has_value());
  CHECK(tiny->triangle_count() > 0);
}

TEST_CASE("tangents follow the UVs' handedness") {
  sc::Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  m.indices = {0, 1, 2};
  // v = 0 is the image's top row: an image shown upright on the +Y side has v growing
  // downwards, and the bitangent w * cross(n, t) points up (+Y), the normal map's green.
  m.uvs = {{0, 1}, {1, 1}, {0, 0}};
  sc::compute_tangents(m);
  CHECK(near3(vec3(m.tangents[0]), {1, 0, 0}));
  CHECK(m.tangents[0].w == 1.0f);
  CHECK(near3(m.tangents[0].w * glm::cross(m.normals[0], vec3(m.tangents[0])), {0, 1, 0}));
  m.uvs = {{0, 0}, {1, 0}, {0, 1}};  // the image upside down (mirrored in v)
  sc::compute_tangents(m);
  CHECK(m.tangents[0].w == -1.0f);
  m.uvs = {{0, 0}, {0, 0}, {0, 0}};  // degenerate UVs: any orthogonal unit vector
  sc::compute_tangents(m);
  CHECK(std::abs(glm::dot(vec3(m.tangents[0]), m.normals[0])) < 1e-6f);
  CHECK(glm::length(vec3(m.tangents[0])) == doctest::Approx(1.0f));
}

TEST_CASE("camera: the target maps to the NDC centre, near and far to depth 0 and 1, y down") {
  sc::Camera cam;
  cam.position = {3, 2, 5};
  cam.target = {0, 0.5f, -1};
  cam.fov_y_degrees = 60;
  cam.near = 0.5f;
  cam.far = 40;
  REQUIRE(sc::validate(cam).has_value());
  const mat4 vp = cam.projection(16.0f / 9.0f) * cam.view();
  const auto ndc = [&](vec3 p) {
    const vec4 c = vp * vec4(p, 1.0f);
    return vec3(c) / c.w;
  };
  const vec3 centre = ndc(cam.target);
  CHECK(centre.x == doctest::Approx(0.0f).epsilon(1e-5));
  CHECK(centre.y == doctest::Approx(0.0f).epsilon(1e-5));
  const vec3 f = cam.forward();
  CHECK(ndc(cam.position + f * cam.near).z == doctest::Approx(0.0f).epsilon(1e-5));
  CHECK(ndc(cam.position + f * cam.far).z == doctest::Approx(1.0f).epsilon(1e-4));
  const vec3 mid = ndc(cam.position + f * 3.0f);
  CHECK((mid.z > 0.0f && mid.z < 1.0f));
  // A point above the target (world +Y) is in the upper half: negative y in Vulkan's NDC.
  CHECK(ndc(cam.target + vec3(0, 0.5f, 0)).y < 0.0f);
  // The top edge of the field of view is y = -1.
  const vec3 right = glm::normalize(glm::cross(f, cam.up));
  const vec3 up = glm::cross(right, f);
  const float half = glm::radians(30.0f);
  CHECK(ndc(cam.position + (f * std::cos(half) + up * std::sin(half)) * 10.0f).y == doctest::Approx(-1.0f).epsilon(1e-4));

  sc::Camera bad = cam;
  bad.up = f;
  CHECK_FALSE(sc::validate(bad).has_value());
  CHECK(std::isfinite(bad.view()[0][0]));  // view() still finite: it falls back to another up
  bad = cam;
  bad.far = bad.near;
  CHECK_FALSE(sc::validate(bad).has_value());
  bad = cam;
  bad.target = bad.position;
  CHECK_FALSE(sc::validate(bad).has_value());
}

TEST_CASE("camera_framing sees the whole box") {
  sc::Bounds b;
  b.extend(vec3(-1, 0, -2));
  b.extend(vec3(3, 2, 1));
  const sc::Camera cam = sc::camera_framing(b, 40.0f);
  REQUIRE(sc::validate(cam).has_value());
  const mat4 vp = cam.projection(1.0f) * cam.view();
  for (int i = 0; i < 8; ++i) {
    const vec3 corner{(i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y, (i & 4) ? b.max.z : b.min.z};
    const vec4 c = vp * vec4(corner, 1.0f);
    CHECK(std::abs(c.x / c.w) <= 1.0f);
    CHECK(std::abs(c.y / c.w) <= 1.0f);
    CHECK((c.z / c.w > 0.0f && c.z / c.w < 1.0f));
  }
}

TEST_CASE("environment: equirect mapping, rotation, constant colour and map lookup") {
  // Matches shaders/frame.glsl: +X is the map's centre, +Y the top row, +Z at u = 0.75.
  CHECK(sc::equirect_uv({1, 0, 0}).x == doctest::Approx(0.5f));
  CHECK(sc::equirect_uv({1, 0, 0}).y == doctest::Approx(0.5f));
  CHECK(sc::equirect_uv({0, 1, 0}).y == doctest::Approx(0.0f));
  CHECK(sc::equirect_uv({0, -1, 0}).y == doctest::Approx(1.0f));
  CHECK(sc::equirect_uv({0, 0, 1}).x == doctest::Approx(0.75f));
  for (float rot : {0.0f, 37.0f, -90.0f}) {
    for (vec3 d : {vec3(0.3f, 0.2f, -0.9f), vec3(-1, 0.5f, 0.1f), vec3(0.2f, -0.7f, 0.4f)}) {
      d = glm::normalize(d);
      CHECK(near3(sc::equirect_direction(sc::equirect_uv(d, rot), rot), d, 1e-5f));
    }
  }
  // Turning the map by 90 degrees moves what was seen along +X.
  CHECK(near3(sc::equirect_direction({0.5f, 0.5f}, 90.0f), {0, 0, 1}, 1e-6f));

  sc::Environment constant;
  constant.constant_color = {0.2f, 0.4f, 0.6f};
  constant.intensity = 2.0f;
  CHECK(near3(constant.radiance({0, 1, 0}), {0.4f, 0.8f, 1.2f}));

  // A 4x2 map, each texel its own colour; the direction at a texel centre reads that texel.
  sc::Environment env;
  env.map = weft::image::Image::filled(4, 2, 3);
  for (std::uint32_t y = 0; y < 2; ++y) {
    for (std::uint32_t x = 0; x < 4; ++x) env.map->at(x, y, 0) = float(y * 4 + x);
  }
  for (std::uint32_t y = 0; y < 2; ++y) {
    for (std::uint32_t x = 0; x < 4; ++x) {
      const vec3 d = sc::equirect_direction({(x + 0.5f) / 4.0f, (y + 0.5f) / 2.0f});
      CHECK(env.radiance(d).x == doctest::Approx(float(y * 4 + x)).epsilon(1e-4));
    }
  }
}

TEST_CASE("load_environment: .hdr round trip, gray to RGB, bad samples repaired; errors name the file") {
  TempDir dir;
  weft::image::Image img = weft::image::Image::filled(8, 4, 3, 0.5f);
  img.at(1, 1, 0) = 4.0f;
  REQUIRE(weft::image::save_hdr(dir / "sky.hdr", img).has_value());
  auto env = sc::load_environment(dir / "sky.hdr");
  REQUIRE_MESSAGE(env.has_value(), env.error().what());
  REQUIRE(env->map.has_value());
  CHECK(env->map->channels == 3);
  CHECK(env->map->width == 8);
  CHECK(env->map->at(1, 1, 0) == doctest::Approx(4.0f).epsilon(0.01));
  CHECK(env->source == dir / "sky.hdr");

  weft::image::Image gray = weft::image::Image::filled(4, 2, 1, 0.25f);
  gray.at(0, 0, 0) = -1.0f;
  REQUIRE(weft::image::save_exr(dir / "gray.exr", gray).has_value());
  auto g = sc::load_environment(dir / "gray.exr");
  REQUIRE_MESSAGE(g.has_value(), g.error().what());
  CHECK(g->map->channels == 3);
  CHECK(g->map->at(1, 0, 2) == doctest::Approx(0.25f));
  CHECK(g->map->at(0, 0, 0) == 0.0f);  // negative radiance repaired

  auto missing = sc::load_environment(dir / "nope.hdr");
  REQUIRE_FALSE(missing.has_value());
  CHECK(contains(missing.error().message, "nope.hdr"));
}
