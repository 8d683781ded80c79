// weft.ssdf on the CPU: the equal-area direction grid, visibility and SSDF at the extremes
// (sees everything: +π; enclosed: −π; one triangle; a half-space against its analytic
// SSDF), the fast distance transform against the O(D²) reference, the bake and CPCA of a
// small scene at k = 1 and k = triangles, and the .wssdf file (round trip, every kind of
// corruption). Small resolutions: the paper-sized numbers live in bench/ssdf_bench.cpp.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <span>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.cluster;
import weft.scene;
import weft.ssdf;

using namespace weft;

namespace {
ssdf::BakeMesh mesh_of(const scene::Mesh& mesh, const mat4& transform = mat4(1.0f)) {
  scene::Scene s;
  s.meshes.push_back(mesh);
  s.objects.push_back({.name = "m", .mesh = 0, .material = 0, .transform = transform});
  auto merged = ssdf::merge_scene(s);
  REQUIRE(merged);
  return *merged;
}

std::vector<float> ssdf_of(const ssdf::BakeMesh& occluders, const ssdf::Probe& probe, const ssdf::DirectionGrid& grid,
                           float offset = 1e-4f) {
  auto vis = ssdf::bake_visibility(occluders, std::span(&probe, 1), grid, {.offset = offset, .threads = 1});
  REQUIRE(vis);
  std::vector<float> out(grid.size());
  ssdf::signed_distance(grid, vis->of(0), out);
  return out;
}

bool all_finite_bounded(const std::vector<float>& values) {
  return std::ranges::all_of(values, [](float v) { return std::isfinite(v) && std::abs(v) <= pi + 1e-6f; });
}

scene::Scene small_scene() {
  scene::Scene s;
  s.meshes.push_back(*scene::make_sphere(0.5f, 10));
  s.meshes.push_back(*scene::make_plane(3.0f, 4));
  s.objects.push_back({.name = "ball", .mesh = 0, .material = 0,
                       .transform = scene::Transform{.translation = {0.0f, 0.5f, 0.0f}}.matrix()});
  s.objects.push_back({.name = "floor", .mesh = 1, .material = 0, .transform = mat4(1.0f)});
  return s;
}
}  // namespace

TEST_CASE("direction grid: equal-area map round trip, cells, symmetric neighbours") {
  for (std::uint32_t n : {1u, 2u, 5u, 16u}) {
    CAPTURE(n);
    const ssdf::DirectionGrid grid(n);
    REQUIRE(grid.size() == std::size_t(n) * n);
    for (std::size_t c = 0; c < grid.size(); ++c) {
      const vec3 d = grid.direction(c);
      CHECK(glm::length(d) == doctest::Approx(1.0f).epsilon(1e-5));
      CHECK(grid.cell_of(d) == c);
      for (std::uint32_t nb : grid.neighbours(c)) {
        CHECK(nb != c);
        const auto back = grid.neighbours(nb);
        CHECK(std::ranges::find(back, std::uint32_t(c)) != back.end());
        if (n >= 5) CHECK(std::acos(std::clamp(glm::dot(d, grid.direction(nb)), -1.0f, 1.0f)) < 3.0f * grid.spacing());
      }
    }
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    const vec2 p(u(rng), u(rng));
    const vec2 q = ssdf::sphere_to_square(ssdf::square_to_sphere(p));
    CHECK(glm::length(p - q) < 1e-4f);
  }
  // Equal area: the fraction of cells in the upper hemisphere is one half, and in the cap
  // z > 0.5 one quarter (area 2π(1 − 0.5) of 4π).
  const ssdf::DirectionGrid grid(64);
  std::size_t upper = 0, cap = 0;
  for (auto d : grid.directions()) upper += d.z > 0.0f, cap += d.z > 0.5f;
  CHECK(double(upper) / grid.size() == doctest::Approx(0.5).epsilon(0.04));  // cells straddle the equator
  CHECK(double(cap) / grid.size() == doctest::Approx(0.25).epsilon(0.02));
}

TEST_CASE("a probe that sees everything has SSDF +π everywhere; an enclosed one −π") {
  const ssdf::DirectionGrid grid(12);
  const ssdf::BakeMesh nothing;
  const auto open = ssdf_of(nothing, {{0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}}, grid, 1e-3f);
  for (float v : open) CHECK(v == pi);
  const auto cube = mesh_of(*scene::make_cube(2.0f));
  const auto enclosed = ssdf_of(cube, {{0.1f, -0.2f, 0.3f}, {0.0f, 1.0f, 0.0f}}, grid);
  for (float v : enclosed) CHECK(v == -pi);
  std::vector<float> exact(grid.size());
  std::vector<std::uint8_t> ones(grid.size(), 1), zeros(grid.size(), 0);
  ssdf::signed_distance_exact(grid, ones, exact);
  for (float v : exact) CHECK(v == pi);
  ssdf::signed_distance_exact(grid, zeros, exact);
  for (float v : exact) CHECK(v == -pi);
  // One occluded cell: the rest see the distance to it; it sees the nearest open cell.
  ones[40] = 0;
  std::vector<float> fast(grid.size());
  ssdf::signed_distance(grid, ones, fast);
  ssdf::signed_distance_exact(grid, ones, exact);
  CHECK(fast[40] < 0.0f);
  for (std::size_t c = 0; c < grid.size(); ++c) CHECK(fast[c] == doctest::Approx(exact[c]).epsilon(1e-5));
}

TEST_CASE("single-triangle scene: finite, bounded, occluded below, open above") {
  scene::Mesh tri;
  tri.positions = {{-1.0f, 0.0f, -1.0f}, {1.0f, 0.0f, -1.0f}, {0.0f, 0.0f, 1.0f}};
  tri.normals = {{0.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}};
  tri.indices = {0, 2, 1};
  const auto mesh = mesh_of(tri);
  const ssdf::DirectionGrid grid(16);
  const auto above = ssdf_of(mesh, {{0.0f, 0.2f, -0.3f}, {0.0f, 1.0f, 0.0f}}, grid);
  CHECK(all_finite_bounded(above));
  CHECK(above[grid.cell_of({0.0f, -1.0f, 0.0f})] < 0.0f);
  CHECK(above[grid.cell_of({0.0f, 1.0f, 0.0f})] > 0.0f);
  CHECK(above[grid.cell_of({1.0f, 0.2f, 0.0f})] > 0.0f);
  // The triangle's own vertices (rays leave just above it): finite and mostly open.
  auto vis = ssdf::bake_visibility(mesh, ssdf::vertex_probes(mesh), grid);
  REQUIRE(vis);
  const auto all = ssdf::signed_distances(grid, *vis, 2);
  CHECK(all_finite_bounded(all.values));
  CHECK(std::ranges::count_if(all.values, [](float v) { return v > 0.0f; }) > std::ptrdiff_t(all.values.size() / 2));
}

TEST_CASE("half-space occluder: the SSDF is the elevation above the horizon, within one cell") {
  const auto floor = mesh_of(*scene::make_plane(1e4f, 1));
  for (std::uint32_t n : {16u, 32u}) {
    CAPTURE(n);
    const ssdf::DirectionGrid grid(n);
    const auto values = ssdf_of(floor, {{0.0f, 0.01f, 0.0f}, {0.0f, 1.0f, 0.0f}}, grid, 1e-7f);
    double worst = 0.0, mean = 0.0;
    for (std::size_t c = 0; c < grid.size(); ++c) {
      const double analytic = std::asin(double(grid.direction(c).y));
      const double error = std::abs(values[c] - analytic);
      CHECK(((values[c] > 0.0f) == (analytic > 0.0)));
      worst = std::max(worst, error);
      mean += error / double(grid.size());
    }
    MESSAGE("n = " << n << ": half-space SSDF error max " << worst << " rad, mean " << mean << " rad, spacing "
                   << grid.spacing());
    // A sample's distance to the nearest opposite sample exceeds its distance to the true
    // horizon by at most about one cell.
    CHECK(worst < 1.5 * grid.spacing());
    CHECK(mean < 0.75 * grid.spacing());
  }
}

TEST_CASE("fast distance transform against the exact O(D²) reference") {
  // Visibility of a small scene's vertices plus random blobs on the sphere.
  const auto s = small_scene();
  auto merged = ssdf::merge_scene(s);
  REQUIRE(merged);
  for (std::uint32_t n : {8u, 24u}) {
    CAPTURE(n);
    const ssdf::DirectionGrid grid(n);
    auto vis = ssdf::bake_visibility(*merged, ssdf::vertex_probes(*merged), grid);
    REQUIRE(vis);
    std::mt19937 rng(n);
    for (int blob = 0; blob < 20; ++blob) {
      std::vector<std::uint8_t> mask(grid.size(), 1);
      std::normal_distribution<float> g;
      for (int k = 0; k < 3; ++k) {
        const vec3 centre = glm::normalize(vec3(g(rng), g(rng), g(rng)));
        const float radius = 0.2f + 0.3f * float(k);
        for (std::size_t c = 0; c < grid.size(); ++c)
          if (glm::dot(grid.direction(c), centre) > std::cos(radius)) mask[c] ^= 1;
      }
      vis->visible.insert(vis->visible.end(), mask.begin(), mask.end());
      ++vis->probe_count;
    }
    const auto fast = ssdf::signed_distances(grid, *vis, 2, false);
    const auto exact = ssdf::signed_distances(grid, *vis, 2, true);
    const auto error = ssdf::measure_error(exact, fast);
    std::size_t different = 0;
    for (std::size_t i = 0; i < fast.values.size(); ++i) different += std::abs(fast.values[i] - exact.values[i]) > 1e-5f;
    MESSAGE("n = " << n << ": fast vs exact over " << vis->probe_count << " probes: RMSE " << error.rmse << " rad, max "
                   << error.max_abs << " rad, " << different << " of " << fast.values.size() << " cells differ by more than 1e-5");
    CHECK(error.sign_error_rate == 0.0);
    CHECK(error.max_abs < grid.spacing());
    CHECK(error.rmse < 0.02 * grid.spacing());
  }
}

TEST_CASE("bake a small scene; CPCA at k = 1, k = triangles, full rank and m = 0") {
  const auto s = small_scene();
  ssdf::BakeOptions options{.resolution = 8};
  options.compression.clusters = 4;
  options.compression.max_components = 1000;
  auto baked = ssdf::bake(s, options);
  REQUIRE(baked);
  const std::size_t vertices = baked->mesh.vertex_count();
  CHECK(baked->raw.rows == vertices);
  CHECK(baked->raw.cols == 64);
  CHECK(all_finite_bounded(baked->raw.values));
  // Floor vertices far from the ball see the upper hemisphere: positive straight up.
  CHECK(baked->raw.at(vertices - 1, ssdf::DirectionGrid(8).cell_of({0.0f, 1.0f, 0.0f})) > 0.0f);
  auto full = ssdf::measure_error(baked->raw, baked->compressed.cpca);
  CHECK(full.max_abs < 1e-4);
  CHECK(full.sign_error_rate == 0.0);
  for (std::size_t k : {std::size_t(1), baked->mesh.triangle_count(), baked->mesh.triangle_count() + 5}) {
    for (auto seeding : {cluster::Seeding::KMeansPlusPlus, cluster::Seeding::FarthestPoint}) {
      CAPTURE(k);
      auto c = ssdf::compress(baked->mesh, baked->raw,
                              {.clusters = k, .seeding = seeding, .max_components = 1000, .threads = 2});
      REQUIRE(c);
      CHECK(ssdf::measure_error(baked->raw, c->cpca).max_abs < 1e-4);
      auto none = ssdf::compress(baked->mesh, baked->raw, {.clusters = k, .seeding = seeding, .max_components = 0});
      REQUIRE(none);
      const auto e = ssdf::measure_error(baked->raw, none->cpca);
      CHECK(std::isfinite(e.rmse));
      if (k >= baked->mesh.triangle_count()) CHECK(none->cpca.total_components() == 0);
    }
  }
  auto energy = ssdf::compress(baked->mesh, baked->raw, {.clusters = 4, .max_components = 1000, .energy_fraction = 0.9});
  REQUIRE(energy);
  CHECK(energy->cpca.compressed_bytes() < baked->compressed.cpca.compressed_bytes());
  CHECK(ssdf::measure_error(baked->raw, energy->cpca).rmse > 0.0);
}

TEST_CASE(".wssdf round trip in every coefficient format, and every kind of corruption") {
  const auto s = small_scene();
  auto baked = ssdf::bake(s, {.resolution = 6, .compression = {.clusters = 3, .max_components = 5}});
  REQUIRE(baked);
  for (auto format : {cluster::CoefficientFormat::Float32, cluster::CoefficientFormat::Float16,
                      cluster::CoefficientFormat::Unorm8}) {
    for (bool center : {true, false}) {
      const bool half_basis = center == (format == cluster::CoefficientFormat::Float16);
      CAPTURE(cluster::to_string(format));
      CAPTURE(center);
      CAPTURE(half_basis);
      ssdf::CompressOptions options{.clusters = 3, .max_components = 5, .center = center, .coefficients = format,
                                    .half_basis = half_basis};
      auto c = ssdf::compress(baked->mesh, baked->raw, options);
      REQUIRE(c);
      const auto asset = ssdf::make_asset(6, options, c->cpca);
      const auto bytes = ssdf::encode(asset);
      auto back = ssdf::decode(bytes);
      REQUIRE_MESSAGE(back, (back ? "" : back.error().what()));
      CHECK(back->resolution == 6);
      CHECK(back->requested_clusters == 3);
      CHECK(back->requested_components == 5);
      CHECK(back->cpca.cluster_of == c->cpca.cluster_of);
      CHECK(back->cpca.slot_of == c->cpca.slot_of);
      CHECK(back->cpca.half_basis == half_basis);
      CHECK(cluster::reconstruct(back->cpca).values == cluster::reconstruct(c->cpca).values);
    }
  }
  const auto asset = ssdf::make_asset(6, {}, baked->compressed.cpca);
  const auto good = ssdf::encode(asset);
  auto message_of = [](std::vector<std::byte> bytes) {
    auto r = ssdf::decode(bytes, "t.wssdf");
    REQUIRE_FALSE(r);
    return r.error().what();
  };
  // Truncation at every length.
  for (std::size_t size = 0; size < good.size(); ++size) {
    auto r = ssdf::decode(std::span(good).first(size), "t.wssdf");
    REQUIRE_FALSE(r);
    if (size > 0) CHECK(r.error().message.find("truncated") != std::string::npos);
  }
  auto bad_magic = good;
  bad_magic[0] = std::byte{'X'};
  CHECK(message_of(bad_magic).find("not a weft SSDF file") != std::string::npos);
  auto version = good;
  version[8] = std::byte{2};
  auto v = ssdf::decode(version);
  REQUIRE_FALSE(v);
  CHECK(v.error().kind == ErrorKind::Unsupported);
  CHECK(v.error().message.find("version 2") != std::string::npos);
  auto header = good;
  header[20] ^= std::byte{1};
  CHECK(message_of(header).find("header checksum mismatch") != std::string::npos);
  // A flipped bit anywhere in a section's payload.
  for (std::size_t at : {std::size_t(64 + 24 + 3), good.size() - 1, good.size() / 2}) {
    auto flipped = good;
    flipped[at] ^= std::byte{0x10};
    CHECK(message_of(flipped).find("checksum mismatch") != std::string::npos);
  }
  auto trailing = good;
  trailing.push_back(std::byte{0});
  CHECK(message_of(trailing).find("unexpected bytes") != std::string::npos);
  // A forged header with a valid checksum claiming four billion clusters: an error, no
  // allocation.
  auto forged = good;
  const std::uint32_t huge = 0xfffffff0u;
  std::memcpy(forged.data() + 28, &huge, 4);
  const std::uint64_t sum = hash_bytes(std::span(forged).first(56));
  std::memcpy(forged.data() + 56, &sum, 8);
  CHECK(message_of(forged).find("clusters") != std::string::npos);
  // Files.
  const auto dir = std::filesystem::temp_directory_path() / "weft-test-ssdf";
  std::filesystem::create_directories(dir);
  REQUIRE(ssdf::write_file(dir / "a.wssdf", asset));
  auto read = ssdf::read_file(dir / "a.wssdf");
  REQUIRE(read);
  CHECK(read->cpca.row_count == baked->mesh.vertex_count());
  auto missing = ssdf::read_file(dir / "missing.wssdf");
  REQUIRE_FALSE(missing);
  CHECK(missing.error().kind == ErrorKind::NotFound);
  CHECK_FALSE(ssdf::write_file(dir / "no" / "such" / "dir.wssdf", asset));
  std::filesystem::remove_all(dir);
}
