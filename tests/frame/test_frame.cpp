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
