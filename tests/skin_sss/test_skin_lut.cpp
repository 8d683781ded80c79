// The pre-integrated skin LUT on the CPU: the profile, the ring integral's limits and
// extremes, the LUT's invariants (finite, in [0, 1], monotone, exact borders), the
// Beckmann alpha, determinism across thread counts, the cache, and the brute-force
// references against each other. Small LUTs: the sweeps live in bench/skin_bench.cpp.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <fstream>
#include <vector>
#include <glm/glm.hpp>
#include <sys/wait.h>
#include <unistd.h>
import weft.core;
import weft.image;
import weft.scene;
import weft.pass.skin_sss;

using namespace weft;
using skin::dvec3;

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

bool finite_unit(const dvec3& d) {
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(d[c]) || d[c] < 0.0 || d[c] > 1.0) return false;
  return true;
}

skin::SkinLut small_lut(skin::IntegrationRange range, std::uint32_t size = 32, std::uint32_t threads = 0) {
  auto lut = skin::generate_lut({.width = size, .height = size, .range = range, .samples = 128, .threads = threads});
  REQUIRE_MESSAGE(lut, (lut ? "" : lut.error().message));
  return std::move(*lut);
}

const skin::IntegrationRange kRanges[] = {skin::IntegrationRange::Penner, skin::IntegrationRange::Adaptive,
                                          skin::IntegrationRange::Full};
}  // namespace

TEST_CASE("profile: each channel's weights sum to 1 and both normalisations integrate to 1") {
  dvec3 sum(0.0);
  for (const auto& g : skin::skin_profile()) sum += g.weight;
  CHECK(sum.x == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(sum.y == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(sum.z == doctest::Approx(1.0).epsilon(1e-9));
  // Planar: ∫ R(d) 2πd dd = 1; ring: ∫ R(x) dx over the line = 1.
  dvec3 planar(0.0), ring(0.0);
  const double h = 0.0005;
  for (double d = 0.5 * h; d < 40.0; d += h) {
    planar += skin::profile(d, skin::physical_convention) * (2.0 * kPi * d * h);
    ring += skin::profile(d, skin::default_convention) * (2.0 * h);
  }
  for (int c = 0; c < 3; ++c) {
    CHECK(planar[c] == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(ring[c] == doctest::Approx(1.0).epsilon(1e-3));
  }
  // Red reaches furthest: at 2 mm red dominates, at 0 blue does (d'Eon's figure).
  const dvec3 far = skin::profile(2.0), near = skin::profile(0.0);
  CHECK(far.x > 10.0 * far.y);
  CHECK(near.z > near.x);
}

TEST_CASE("integration ranges: Penner ±π/2, adaptive ±π(r+1)/2r (2π at r = 1, tending to π), capped at the ring") {
  CHECK(skin::half_range(skin::IntegrationRange::Penner, 1.0) == doctest::Approx(kPi / 2));
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, 1.0) == doctest::Approx(kPi));
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, 3.0) == doctest::Approx(kPi * 4.0 / 6.0));
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, 1e9) == doctest::Approx(kPi / 2).epsilon(1e-6));
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, kInf) == doctest::Approx(kPi / 2));
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, 0.25) == doctest::Approx(kPi));  // r < 1: the whole ring
  CHECK(skin::half_range(skin::IntegrationRange::Adaptive, 0.0) == doctest::Approx(kPi));
  CHECK(skin::half_range(skin::IntegrationRange::Full, 50.0) == doctest::Approx(kPi));
  CHECK(skin::integration_range_from_string("adaptive").value() == skin::IntegrationRange::Adaptive);
  CHECK(!skin::integration_range_from_string("wide"));
}

TEST_CASE("1/r -> 0: D tends to max(cos θ, 0) for every range, convention and quadrature") {
  for (auto range : kRanges)
    for (auto conv : {skin::default_convention, skin::thesis_convention, skin::penner_convention})
      for (auto quad : {skin::Quadrature::PerGaussian, skin::Quadrature::Uniform})
        for (double theta : {0.0, 0.3, kPi / 4, kPi / 2 - 0.1, kPi / 2, kPi / 2 + 0.1, 2.0, kPi}) {
          const skin::RingOptions o{range, conv, 256, quad};
          const double flat = std::max(std::cos(theta), 0.0);
          CAPTURE(theta);
          CAPTURE(int(range));
          CAPTURE(int(quad));
          const dvec3 inf = skin::integrate_ring(std::cos(theta), kInf, o);
          CHECK(inf == dvec3(flat));
          const dvec3 huge = skin::integrate_ring(std::cos(theta), 1e6, o);
          CHECK(finite_unit(huge));
          for (int c = 0; c < 3; ++c) CHECK(huge[c] == doctest::Approx(flat).epsilon(1e-4).scale(1.0));
          const dvec3 big = skin::integrate_ring(std::cos(theta), 1e3, o);  // r = 1 m
          if (quad == skin::Quadrature::PerGaussian)
            for (int c = 0; c < 3; ++c) CHECK(std::abs(big[c] - flat) < 3e-3);
        }
}

TEST_CASE("the smallest radii stay finite and bounded; r -> 0 averages cos⁺ over the range") {
  for (auto range : kRanges)
    for (double r : {1.0, 0.5, 0.1, 1e-3, 1e-9, 0.0, -1.0})
      for (double c : {-1.0, -0.5, 0.0, 0.5, 1.0}) {
        CAPTURE(r);
        CAPTURE(c);
        CHECK(finite_unit(skin::integrate_ring(c, r, {.range = range})));
      }
  // As r -> 0 the profile is constant over the ring: D = (1/2X) ∫_{-X}^{X} cos⁺(θ + x) dx.
  const double theta = 1.0;
  const dvec3 full = skin::integrate_ring(std::cos(theta), 1e-6, {.range = skin::IntegrationRange::Full, .samples = 4096});
  for (int c = 0; c < 3; ++c) CHECK(full[c] == doctest::Approx(1.0 / kPi).epsilon(1e-3));
  const dvec3 penner = skin::integrate_ring(std::cos(theta), 1e-6, {.range = skin::IntegrationRange::Penner, .samples = 4096});
  // ∫_{-π/2}^{π/2} cos⁺(1 + x) dx / π = (1 - sin(1 - π/2)) / π... cos⁺ is positive for x < π/2 - 1.
  const double expected = (std::sin(kPi / 2) - std::sin(1.0 - kPi / 2)) / kPi;
  for (int c = 0; c < 3; ++c) CHECK(penner[c] == doctest::Approx(expected).epsilon(1e-3));
  CHECK(skin::integrate_ring(0.5, std::nan(""), {}) == dvec3(0.5));
}

TEST_CASE("θ = 0, π/2, π: bounded by the flat values, light wraps past the terminator, red furthest") {
  for (auto range : kRanges)
    for (double r : {1.0, 2.0, 5.0, 20.0}) {
      CAPTURE(r);
      CAPTURE(int(range));
      const dvec3 lit = skin::integrate_ring(1.0, r, {.range = range});
      const dvec3 terminator = skin::integrate_ring(0.0, r, {.range = range});
      const dvec3 back = skin::integrate_ring(-1.0, r, {.range = range});
      CHECK(finite_unit(lit));
      CHECK(finite_unit(terminator));
      CHECK(finite_unit(back));
      for (int c = 0; c < 3; ++c) {
        CHECK(lit[c] <= 1.0);
        CHECK(lit[c] > 0.5);
        CHECK(terminator[c] > 0.0);  // scattering carries light past N·L = 0
        CHECK(back[c] <= terminator[c]);
      }
      CHECK(terminator.x > terminator.y);  // red scatters furthest
      CHECK(terminator.y >= terminator.z);
      if (range == skin::IntegrationRange::Penner) CHECK(back == dvec3(0.0));  // ±π/2 never reaches the lit side
    }
}

TEST_CASE("tiny and huge variances: the flat limit and the range average") {
  const skin::RingOptions planar{.range = skin::IntegrationRange::Full, .convention = {skin::Normalization::Planar, 1e-9},
                                 .samples = 512};
  const skin::RingOptions wide{.range = skin::IntegrationRange::Full, .convention = {skin::Normalization::Ring, 1e9},
                               .samples = 512};
  for (double theta : {0.0, 1.0, kPi / 2, 2.5, kPi}) {
    CAPTURE(theta);
    const dvec3 sharp = skin::integrate_ring(std::cos(theta), 5.0, planar);
    for (int c = 0; c < 3; ++c) CHECK(sharp[c] == doctest::Approx(std::max(std::cos(theta), 0.0)).epsilon(1e-4).scale(1.0));
    const dvec3 flat_kernel = skin::integrate_ring(std::cos(theta), 5.0, wide);
    for (int c = 0; c < 3; ++c) CHECK(flat_kernel[c] == doctest::Approx(1.0 / kPi).epsilon(1e-3));
  }
  CHECK(!skin::validate(skin::LutParams{.convention = {skin::Normalization::Ring, 0.0}}));
}

TEST_CASE("the LUT: no NaN, in [0, 1], exact flat row and borders, monotone in N·L, red >= green >= blue past the terminator") {
  for (auto range : kRanges) {
    CAPTURE(int(range));
    const auto lut = small_lut(range);
    for (std::uint32_t y = 0; y < lut.height; ++y)
      for (std::uint32_t x = 0; x < lut.width; ++x) {
        const vec4 t = lut.texel(x, y);
        for (int c = 0; c < 4; ++c) {
          REQUIRE(std::isfinite(t[c]));
          CHECK(t[c] >= 0.0f);
          CHECK(t[c] <= 1.0f);
        }
      }
    // Row 0 is the flat limit, exactly; N·L = ±1 lie on texel centres.
    for (std::uint32_t x = 0; x < lut.width; ++x) {
      const float flat = float(std::max(lut.n_dot_l_at(x), 0.0));
      CHECK(vec3(lut.texel(x, 0)) == vec3(flat));
    }
    CHECK(lut.n_dot_l_at(0) == -1.0);
    CHECK(lut.n_dot_l_at(lut.width - 1) == 1.0);
    CHECK(lut.curvature_at(0) == 0.0);
    CHECK(lut.curvature_at(lut.height - 1) == doctest::Approx(1.0));
    for (std::uint32_t y = 0; y < lut.height; ++y) {
      CHECK(skin::sample_diffuse(lut, 1.0f, float(lut.curvature_at(y))) == vec3(lut.texel(lut.width - 1, y)));
      CHECK(skin::sample_diffuse(lut, -1.0f, float(lut.curvature_at(y))) == vec3(lut.texel(0, y)));
      CHECK(skin::sample_diffuse(lut, 7.0f, float(lut.curvature_at(y))) == vec3(lut.texel(lut.width - 1, y)));  // clamped
      for (std::uint32_t x = 1; x < lut.width; ++x)
        for (int c = 0; c < 3; ++c) CHECK(lut.texel(x, y)[c] >= lut.texel(x - 1, y)[c] - 1e-6f);
      const vec4 t = lut.texel(lut.width / 2 - 1, y);  // just past the terminator
      CHECK(t.r >= t.g - 1e-6f);
      CHECK(t.g >= t.b - 1e-6f);
    }
    CHECK(skin::lut_coordinate(0.0f, 32) == doctest::Approx(0.5f / 32));
    CHECK(skin::lut_coordinate(1.0f, 32) == doctest::Approx(31.5f / 32));
    CHECK(skin::lut_coordinate(std::nanf(""), 32) == doctest::Approx(0.5f / 32));
  }
}

TEST_CASE("the adaptive range lets more light past the terminator than Penner's on tight curves, and agrees on flat ones") {
  const auto penner = small_lut(skin::IntegrationRange::Penner);
  const auto adaptive = small_lut(skin::IntegrationRange::Adaptive);
  const vec3 p_tight = skin::sample_diffuse(penner, -0.2f, 1.0f), a_tight = skin::sample_diffuse(adaptive, -0.2f, 1.0f);
  CHECK(a_tight.r > p_tight.r);
  const vec3 p_flat = skin::sample_diffuse(penner, 0.3f, 0.02f), a_flat = skin::sample_diffuse(adaptive, 0.3f, 0.02f);
  CHECK(std::abs(p_flat.r - a_flat.r) < 1e-3f);
}

TEST_CASE("generation is deterministic: one thread and many give identical texels; hashes key the content") {
  const auto one = small_lut(skin::IntegrationRange::Adaptive, 24, 1);
  const auto many = small_lut(skin::IntegrationRange::Adaptive, 24, 4);
  CHECK(one.texels == many.texels);
  skin::LutParams a{.width = 24, .height = 24}, b = a;
  b.threads = 7;
  CHECK(a.hash() == b.hash());  // threads do not change texels
  b.range = skin::IntegrationRange::Penner;
  CHECK(a.hash() != b.hash());
  b = a;
  b.convention = skin::thesis_convention;
  CHECK(a.hash() != b.hash());
  b = a;
  b.samples = 64;
  CHECK(a.hash() != b.hash());
  CHECK(!skin::generate_lut({.width = 1}));
  CHECK(!skin::generate_lut({.max_curvature = 0.0}));
  CHECK(!skin::generate_lut({.samples = 1}));
  CHECK(!skin::generate_lut({.height = 5000}));
}

TEST_CASE("quadrature: 64 samples per Gaussian are within 1e-3 of 4096; the uniform grid needs far more on gentle curves") {
  double worst_per_gaussian = 0.0, worst_uniform = 0.0;
  for (double r : {1.0, 3.0, 10.0, 50.0})
    for (double c : {-0.5, -0.1, 0.0, 0.2, 0.7}) {
      const dvec3 ref = skin::integrate_ring(c, r, {.samples = 4096});
      const dvec3 coarse = skin::integrate_ring(c, r, {.samples = 64});
      const dvec3 uniform = skin::integrate_ring(c, r, {.samples = 64, .quadrature = skin::Quadrature::Uniform});
      for (int k = 0; k < 3; ++k) {
        worst_per_gaussian = std::max(worst_per_gaussian, std::abs(coarse[k] - ref[k]));
        worst_uniform = std::max(worst_uniform, std::abs(uniform[k] - ref[k]));
      }
    }
  CHECK(worst_per_gaussian < 1e-3);
  CHECK(worst_uniform > worst_per_gaussian);
}

TEST_CASE("Beckmann in the alpha channel: finite, in [0, 1], decodes to the KS term, peaks at N·H = 1") {
  const auto lut = small_lut(skin::IntegrationRange::Adaptive, 64);
  CHECK(skin::beckmann(0.0, 0.3) == 0.0);
  CHECK(skin::beckmann(-0.5, 0.3) == 0.0);
  CHECK(std::isinf(skin::beckmann(1.0, 0.0)));
  CHECK(skin::beckmann(0.9, 0.0) == 0.0);
  CHECK(skin::beckmann(1.0, 0.3) == doctest::Approx(1.0 / 0.09));
  CHECK(skin::encode_beckmann(std::numeric_limits<double>::infinity()) == 1.0);
  CHECK(skin::encode_beckmann(std::nan("")) == 0.0);
  CHECK(skin::decode_beckmann(skin::encode_beckmann(20.0)) == doctest::Approx(20.0));
  for (float m : {0.2f, 0.3f, 0.5f}) {
    CAPTURE(m);
    float previous = -1.0f;
    for (float nh = 0.0f; nh <= 1.0f; nh += 0.05f) {
      const float sampled = skin::sample_specular(lut, nh, m);
      CHECK(std::isfinite(sampled));
      CHECK(sampled >= previous - 1e-3f);  // monotone towards the peak at N·H = 1
      previous = sampled;
      const double exact = skin::beckmann(nh, m);
      if (nh > 0.5f) CHECK(sampled == doctest::Approx(exact).epsilon(0.15));
    }
  }
  // The KS specular is bounded and vanishes under the horizon.
  const dvec3 n(0, 0, 1), v = glm::normalize(dvec3(0.3, 0, 1));
  CHECK(skin::ks_specular(n, glm::normalize(dvec3(-0.3, 0, 1)), v, 0.3, 0.18) > 0.0);
  CHECK(skin::ks_specular(n, dvec3(0, 0, -1), v, 0.3, 0.18) == 0.0);
  CHECK(skin::ks_specular(n, -v, v, 0.3, 0.18) == 0.0);  // L + V = 0
  CHECK(std::isfinite(skin::ks_specular(n, n, n, 1e-6, 0.18)));
  CHECK(skin::fresnel_schlick(1.0) == doctest::Approx(0.028));
  CHECK(skin::fresnel_schlick(0.0) == doctest::Approx(1.0));
}

TEST_CASE("transmittance: 1 through nothing, falling with thickness, blue first, 0 through infinity") {
  CHECK(skin::transmittance(0.0).x == doctest::Approx(1.0));
  const dvec3 thin = skin::transmittance(0.5), thick = skin::transmittance(3.0);
  CHECK(thin.x > thin.z);
  CHECK(thick.x < thin.x);
  CHECK(skin::transmittance(kInf) == dvec3(0.0));
  CHECK(skin::transmittance(std::nan("")) == dvec3(0.0));
}

TEST_CASE("sphere reference: flat limit, uniform light gives 1, agrees with the LUT on a gentle sphere") {
  for (double c : {-1.0, -0.2, 0.0, 0.4, 1.0}) {
    CHECK(skin::sphere_reference(c, kInf) == dvec3(std::max(c, 0.0)));
    const dvec3 big = skin::sphere_reference(c, 1e4, skin::physical_convention, 2048);
    for (int k = 0; k < 3; ++k) CHECK(big[k] == doctest::Approx(std::max(c, 0.0)).epsilon(1e-3).scale(1.0));
    CHECK(finite_unit(skin::sphere_reference(c, 1e-6)));
    CHECK(finite_unit(skin::sphere_reference(c, 0.5)));
  }
  // On a 50 mm sphere the LUT and the reference differ by little.
  const auto lut = small_lut(skin::IntegrationRange::Adaptive, 64);
  for (double c : {-0.1, 0.0, 0.3, 0.8}) {
    const dvec3 ref = skin::sphere_reference(c, 50.0, skin::physical_convention, 2048);
    const vec3 got = skin::sample_diffuse(lut, float(c), 1.0f / 50.0f);
    for (int k = 0; k < 3; ++k) CHECK(std::abs(got[k] - ref[k]) < 0.02);
  }
}

TEST_CASE("mesh reference on a sphere mesh agrees with the exact sphere reference") {
  // A 4 mm sphere (radius 4 units at 1 mm per unit), lit from +x.
  auto mesh = scene::make_sphere(4.0f, 48);
  REQUIRE(mesh);
  const vec3 light(1.0f, 0.0f, 0.0f);
  auto got = skin::mesh_reference(*mesh, {.towards_light = light, .mm_per_unit = 1.0, .min_cell_mm = 0.05, .refine = 4.0});
  REQUIRE_MESSAGE(got, (got ? "" : got.error().message));
  double worst = 0.0;
  for (std::size_t i = 0; i < mesh->positions.size(); i += 7) {
    const double c = glm::dot(glm::normalize(mesh->positions[i]), light);
    const dvec3 ref = skin::sphere_reference(c, 4.0, skin::physical_convention, 1024);
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(double((*got)[i][k]) - ref[k]));
  }
  CHECK(worst < 0.03);
  CHECK(!skin::mesh_reference(scene::Mesh{}, {}));
  CHECK(!skin::mesh_reference(*mesh, {.towards_light = vec3(0.0f)}));
}

TEST_CASE("curvature inputs: a flat plane, a cusp and a degenerate triangle give finite lookups") {
  const auto lut = small_lut(skin::IntegrationRange::Adaptive, 16);
  auto lookup_all = [&](const scene::Mesh& mesh, float mm_per_unit) {
    for (std::size_t i = 0; i < mesh.curvature.size(); ++i) {
      const float k = mesh.curvature[i] / mm_per_unit;
      CHECK(std::isfinite(k));
      CHECK(k >= 0.0f);
      const vec3 d = skin::sample_diffuse(lut, 0.0f, k);
      CHECK(std::isfinite(d.r + d.g + d.b));
    }
  };
  auto plane = scene::make_plane(1.0f, 8);
  REQUIRE(plane);
  for (float k : plane->curvature) CHECK(k == 0.0f);
  lookup_all(*plane, 1000.0f);
  CHECK(skin::sample_diffuse(lut, 0.5f, plane->curvature[0]) == vec3(0.5f));  // flat: max(N·L, 0)

  // A cone whose apex normal is the mean of very different face normals (a cusp).
  scene::Mesh cone;
  cone.name = "cusp";
  cone.positions.push_back({0.0f, 1.0f, 0.0f});
  for (int i = 0; i < 8; ++i) {
    const float a = 2.0f * float(kPi) * i / 8.0f;
    cone.positions.push_back({0.05f * std::cos(a), 0.0f, 0.05f * std::sin(a)});
  }
  for (std::uint32_t i = 0; i < 8; ++i) cone.indices.insert(cone.indices.end(), {0, 1 + (i + 1) % 8, 1 + i});
  REQUIRE(scene::prepare_mesh(cone));
  for (float k : cone.curvature) CHECK(std::isfinite(k));
  CHECK(cone.curvature[0] > 1.0f);
  lookup_all(cone, 1.0f);
  CHECK(skin::sample_diffuse(lut, 0.0f, 1e30f) == skin::sample_diffuse(lut, 0.0f, 1.0f));  // clamped to the last row

  // A triangle with two equal corners next to a good one: curvature stays finite.
  scene::Mesh degenerate;
  degenerate.name = "degenerate";
  degenerate.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}};
  degenerate.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  degenerate.indices = {0, 1, 2, 1, 3, 2};
  scene::compute_curvature(degenerate);
  for (float k : degenerate.curvature) CHECK(k == 0.0f);
  lookup_all(degenerate, 1.0f);
  CHECK(std::isfinite(skin::sample_diffuse(lut, 0.0f, std::nanf("")).r));
}

TEST_CASE("files: EXR round-trips the texels, PNG is a picture, other extensions are refused") {
  const auto lut = small_lut(skin::IntegrationRange::Adaptive, 16);
  const auto dir = std::filesystem::temp_directory_path() / ("weft-skin-lut-" + std::to_string(std::random_device{}()));
  std::filesystem::create_directories(dir);
  REQUIRE(skin::save_lut(dir / "lut.exr", lut));
  auto back = image::load_exr(dir / "lut.exr");
  REQUIRE(back);
  CHECK(back->channels == 4);
  CHECK(back->pixels == skin::to_image(lut).pixels);
  REQUIRE(skin::save_lut(dir / "lut.png", lut));
  auto png = image::load_png(dir / "lut.png");
  REQUIRE(png);
  CHECK(png->channels == 3);
  REQUIRE(skin::save_lut(dir / "lut-rgba.png", lut, true));
  CHECK(image::load_png(dir / "lut-rgba.png")->channels == 4);
  auto bad = skin::save_lut(dir / "lut.tga", lut);
  REQUIRE(!bad);
  CHECK(bad.error().kind == ErrorKind::Unsupported);
  std::filesystem::remove_all(dir);
}

TEST_CASE("cache: a second request is a memory hit; a fresh process finds the disk copy") {
  const auto dir = std::filesystem::temp_directory_path() / ("weft-skin-cache-" + std::to_string(std::random_device{}()));
  ::setenv("WEFT_SKIN_LUT_CACHE", dir.c_str(), 1);
  const skin::LutParams params{.width = 12, .height = 10, .samples = 32};
  const auto before = skin::lut_cache_stats();
  auto first = skin::cached_lut(params);
  REQUIRE(first);
  auto second = skin::cached_lut(params);
  REQUIRE(second);
  CHECK(first->get() == second->get());
  auto after = skin::lut_cache_stats();
  CHECK(after.generated == before.generated + 1);
  CHECK(after.memory_hits == before.memory_hits + 1);
  CHECK(std::filesystem::exists(dir / ("skin-lut-" + hex64(params.hash()) + ".exr")));
  skin::clear_lut_memory_cache();
  auto third = skin::cached_lut(params);
  REQUIRE(third);
  CHECK(skin::lut_cache_stats().disk_hits == after.disk_hits + 1);
  CHECK((*third)->texels == (*first)->texels);
  CHECK(!skin::cached_lut({.width = 0}));
  ::unsetenv("WEFT_SKIN_LUT_CACHE");
  std::filesystem::remove_all(dir);
}

TEST_CASE("cache: processes baking one key at once, a corrupt entry and an unwritable folder never give a bad LUT") {
  const auto dir = std::filesystem::temp_directory_path() / ("weft-skin-cache-race-" + std::to_string(std::random_device{}()));
  ::setenv("WEFT_SKIN_LUT_CACHE", dir.c_str(), 1);
  const skin::LutParams params{.width = 24, .height = 20, .samples = 32, .threads = 1};
  const auto file = dir / ("skin-lut-" + hex64(params.hash()) + ".exr");
  auto expected = skin::generate_lut(params);
  REQUIRE(expected);
  // Four processes, each baking (or reading) the same key ten times with a cold memory cache.
  std::vector<pid_t> children;
  for (int c = 0; c < 4; ++c) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      for (int i = 0; i < 10; ++i) {
        skin::clear_lut_memory_cache();
        if (i % 3 == 0) std::filesystem::remove(file);  // others bake again while this one reads
        auto lut = skin::cached_lut(params);
        if (!lut || (*lut)->texels != expected->texels) ::_exit(1);
      }
      ::_exit(0);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    CHECK((WIFEXITED(status) && WEXITSTATUS(status) == 0));
  }
  for (const auto& e : std::filesystem::directory_iterator(dir)) CHECK_MESSAGE(e.path().extension() != ".tmp", e.path());

  // A torn entry (as a writer without the atomic rename could leave) is re-baked, not used.
  REQUIRE(std::filesystem::exists(file));
  std::filesystem::resize_file(file, std::filesystem::file_size(file) / 2);
  skin::clear_lut_memory_cache();
  auto repaired = skin::cached_lut(params);
  REQUIRE(repaired);
  CHECK((*repaired)->texels == expected->texels);

  // A cache "folder" that is a file: the LUT is still made; the cache is skipped with a warning.
  std::filesystem::remove_all(dir);
  std::ofstream(dir) << "not a folder";
  skin::clear_lut_memory_cache();
  auto uncached = skin::cached_lut(params);
  REQUIRE(uncached);
  CHECK((*uncached)->texels == expected->texels);
  ::unsetenv("WEFT_SKIN_LUT_CACHE");
  std::filesystem::remove(dir);
}
