#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>
import weft.core;
import weft.frame;

using namespace weft;

namespace {
std::vector<float> equirect(std::uint32_t w, std::uint32_t h, auto radiance) {
  std::vector<float> rgb(std::size_t(w) * h * 3);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const float theta = (y + 0.5f) / h * pi;
      const float phi = ((x + 0.5f) / w - 0.5f) * 2 * pi;
      const vec3 d{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
      const vec3 L = radiance(d);
      for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * w + x) * 3 + c] = L[c];
    }
  return rgb;
}
}  // namespace

TEST_CASE("irradiance SH of a constant sky is pi everywhere (white furnace)") {
  const auto rgb = equirect(128, 64, [](vec3) { return vec3(1.0f); });
  const auto sh = frame::irradiance_sh(rgb, 128, 64);
  for (vec3 n : {vec3(0, 1, 0), vec3(0, -1, 0), vec3(1, 0, 0), glm::normalize(vec3(1, -2, 3))}) {
    const vec3 e = frame::evaluate_sh(sh, n);
    CHECK(e.x == doctest::Approx(pi).epsilon(1e-3));
    CHECK(e.z == doctest::Approx(pi).epsilon(1e-3));
  }
}

TEST_CASE("irradiance SH of an upper-hemisphere sky matches the analytic pi(1+cos a)/2") {
  // That function has only SH bands 0 and 1, so order-2 SH is exact up to quadrature error.
  const auto rgb = equirect(256, 128, [](vec3 d) { return d.y > 0 ? vec3(1.0f) : vec3(0.0f); });
  const auto sh = frame::irradiance_sh(rgb, 256, 128);
  CHECK(frame::evaluate_sh(sh, {0, 1, 0}).x == doctest::Approx(pi).epsilon(0.01));
  CHECK(std::abs(frame::evaluate_sh(sh, {0, -1, 0}).x) < 0.02f);
  CHECK(frame::evaluate_sh(sh, {1, 0, 0}).x == doctest::Approx(pi / 2).epsilon(0.01));
}

TEST_CASE("irradiance SH rotation moves a lobe around the vertical axis") {
  const auto rgb = equirect(256, 128, [](vec3 d) { return d.x > 0 ? vec3(1.0f) : vec3(0.0f); });
  const auto sh = frame::irradiance_sh(rgb, 256, 128, pi / 2);
  // Rotating by +90° about y takes +x to -z or +z; either way +x is no longer the bright side.
  CHECK(frame::evaluate_sh(sh, {1, 0, 0}).x == doctest::Approx(pi / 2).epsilon(0.02));
  const float pz = frame::evaluate_sh(sh, {0, 0, 1}).x, nz = frame::evaluate_sh(sh, {0, 0, -1}).x;
  CHECK(std::max(pz, nz) == doctest::Approx(pi).epsilon(0.02));
  CHECK(std::min(pz, nz) < 0.05f);
}

TEST_CASE("NaN and infinite texels are ignored, not propagated") {
  auto rgb = equirect(64, 32, [](vec3) { return vec3(1.0f); });
  rgb[100] = std::nanf("");
  rgb[200] = INFINITY;
  const vec3 e = frame::evaluate_sh(frame::irradiance_sh(rgb, 64, 32), {0, 1, 0});
  CHECK(std::isfinite(e.x));
  CHECK(std::isfinite(e.y));
}

TEST_CASE("Vulkan perspective: target at the centre, near plane at depth 0, far at 1, y down") {
  const mat4 p = frame::perspective_vk(glm::radians(60.0f), 1.5f, 0.1f, 100.0f);
  auto ndc = [&](vec3 v) {
    const vec4 c = p * vec4(v, 1.0f);
    return vec3(c) / c.w;
  };
  CHECK(ndc({0, 0, -0.1f}).z == doctest::Approx(0.0f).epsilon(1e-5));
  CHECK(ndc({0, 0, -100.0f}).z == doctest::Approx(1.0f).epsilon(1e-5));
  CHECK(ndc({0, 1, -5}).y < 0.0f);  // up in view space is up on screen: negative y in Vulkan NDC
}

TEST_CASE("the vertex layout covers the 64-byte vertex with locations 0..4") {
  const auto layout = frame::vertex_layout();
  CHECK(layout.stride == 64);
  REQUIRE(layout.attributes.size() == 5);
  for (std::uint32_t i = 0; i < 5; ++i) CHECK(layout.attributes[i].location == i);
}

TEST_CASE("the exact SH of a constant sky gives pi times its radiance in every direction") {
  const auto sh = frame::constant_irradiance_sh({0.5f, 1.0f, 2.0f});
  for (vec3 n : {vec3(0, 1, 0), vec3(0, 0, -1), glm::normalize(vec3(1, 1, 1))}) {
    const vec3 e = frame::evaluate_sh(sh, n);
    CHECK(e.x == doctest::Approx(0.5f * pi));
    CHECK(e.z == doctest::Approx(2.0f * pi));
  }
}

TEST_CASE("a two-row map integrates to 4 pi: band 0 of a coarse constant sky is exact") {
  std::vector<float> rgb(4 * 2 * 3, 1.0f);
  const auto sh = frame::irradiance_sh(rgb, 4, 2);
  CHECK(sh[0].x == doctest::Approx(frame::constant_irradiance_sh(vec3(1.0f))[0].x).epsilon(1e-5));
}

TEST_CASE("sample jitter: none for sample 0, then the Halton (2, 3) points within the pixel, evenly spread") {
  CHECK(frame::sample_jitter(0) == vec2(0.0f));
  // Halton base 2: 1/2, 1/4, 3/4; base 3: 1/3, 2/3, 1/9 -- less a half.
  CHECK(frame::sample_jitter(1).x == doctest::Approx(0.0f));
  CHECK(frame::sample_jitter(1).y == doctest::Approx(1.0f / 3.0f - 0.5f));
  CHECK(frame::sample_jitter(2).x == doctest::Approx(-0.25f));
  CHECK(frame::sample_jitter(2).y == doctest::Approx(2.0f / 3.0f - 0.5f));
  CHECK(frame::sample_jitter(3).x == doctest::Approx(0.25f));
  CHECK(frame::sample_jitter(3).y == doctest::Approx(1.0f / 9.0f - 0.5f));
  // Every point inside the pixel, and each quarter of the pixel holds a quarter of 64 samples
  // (a low-discrepancy set; random points would be off by several).
  int quarter[2][2] = {{0, 0}, {0, 0}};
  vec2 mean(0.0f);
  for (std::uint32_t i = 0; i < 64; ++i) {
    const vec2 j = frame::sample_jitter(i);
    CHECK(j.x >= -0.5f);
    CHECK(j.x < 0.5f);
    CHECK(j.y >= -0.5f);
    CHECK(j.y < 0.5f);
    ++quarter[j.x >= 0.0f][j.y >= 0.0f];
    mean += j / 64.0f;
  }
  for (auto& row : quarter)
    for (int n : row) CHECK(std::abs(n - 16) <= 2);
  CHECK(std::abs(mean.x) < 0.02f);
  CHECK(std::abs(mean.y) < 0.02f);
  // Far along the sequence (a viewer left still for a long time) the points stay in the pixel.
  for (std::uint32_t i : {1000u, 65535u, 4000000000u}) {
    const vec2 j = frame::sample_jitter(i);
    CHECK((std::isfinite(j.x) && j.x >= -0.5f && j.x < 0.5f && j.y >= -0.5f && j.y < 0.5f));
  }
}

TEST_CASE("a jittered projection moves every point by the jitter in pixels, at every depth") {
  const mat4 p = frame::perspective_vk(glm::radians(50.0f), 1.6f, 0.05f, 50.0f);
  const std::uint32_t w = 160, h = 100;
  const vec2 jitter{0.3f, -0.45f};
  const mat4 moved = frame::jitter_projection(p, jitter, w, h);
  for (vec3 v : {vec3(0, 0, -1), vec3(0.4f, -0.2f, -3), vec3(-2, 1, -40)}) {
    const vec4 a = p * vec4(v, 1.0f), b = moved * vec4(v, 1.0f);
    const vec2 pixels_a = vec2(a) / a.w * vec2(w, h) * 0.5f, pixels_b = vec2(b) / b.w * vec2(w, h) * 0.5f;
    CHECK(pixels_b.x - pixels_a.x == doctest::Approx(jitter.x).epsilon(1e-3));
    CHECK(pixels_b.y - pixels_a.y == doctest::Approx(jitter.y).epsilon(1e-3));
    CHECK(b.z / b.w == doctest::Approx(a.z / a.w));  // depth is untouched
  }
  CHECK(frame::jitter_projection(p, jitter, 0, 0) == p);  // no size: nothing to move by
}
