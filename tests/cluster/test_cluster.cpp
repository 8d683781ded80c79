// weft.cluster: PCA against analytic cases (exact rank, energy fractions, m = 0 and full
// rank), k-means with both seedings at k = 1, k = points, duplicates (all D² zero) and fixed
// seeds, CPCA with both stopping rules and every coefficient format.
#include <doctest/doctest.h>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <set>
#include <vector>
import weft.core;
import weft.cluster;

using namespace weft;
using namespace weft::cluster;

namespace {
Matrix random_matrix(std::size_t rows, std::size_t cols, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Matrix m(rows, cols);
  for (float& v : m.values) v = static_cast<float>(double(rng() >> 11) * 0x1.0p-53 * 2.0 - 1.0);
  return m;
}

// Points a + t u + s v (a plane when v != 0, a line when v == 0) in `cols` dimensions.
Matrix affine_points(std::size_t rows, std::size_t cols, bool plane) {
  Matrix m(rows, cols);
  for (std::size_t r = 0; r < rows; ++r) {
    const double t = double(r) * 0.37 - 2.0, s = std::sin(double(r) * 1.3);
    for (std::size_t c = 0; c < cols; ++c) {
      const double a = 0.5 + 0.1 * double(c), u = std::cos(double(c)), v = plane ? double(c % 3) - 1.0 : 0.0;
      m.at(r, c) = static_cast<float>(a + t * u + s * v);
    }
  }
  return m;
}

double max_abs_difference(const Matrix& a, const Matrix& b) {
  REQUIRE(a.values.size() == b.values.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < a.values.size(); ++i) worst = std::max(worst, std::abs(double(a.values[i]) - b.values[i]));
  return worst;
}

double max_abs(const Matrix& a) {
  double worst = 0.0;
  for (float v : a.values) worst = std::max(worst, std::abs(double(v)));
  return worst;
}
}  // namespace

TEST_CASE("PCA finds the exact rank of points on a line and on a plane") {
  for (bool plane : {false, true}) {
    for (auto [rows, cols] : {std::pair<std::size_t, std::size_t>{40, 7}, {6, 50}}) {
      CAPTURE(plane);
      CAPTURE(rows);
      const Matrix data = affine_points(rows, cols, plane);
      auto pca = fit_pca(data);
      REQUIRE(pca);
      CHECK(pca->rank == (plane ? 2u : 1u));
      CHECK(pca->components() == pca->rank);
      CHECK(pca->energy_fraction(pca->rank) == doctest::Approx(1.0));
      const Matrix back = reconstruct(*pca, project(*pca, data));
      CHECK(max_abs_difference(back, data) < 1e-5 * max_abs(data));
    }
  }
}

TEST_CASE("PCA energy fractions follow the singular values; both stopping rules") {
  // Axis-aligned data with standard deviations 4, 2, 1 on three axes: energies 16:4:1.
  Matrix data(8, 3);
  const float signs[8][3] = {{1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1},
                             {-1, 1, 1}, {-1, 1, -1}, {-1, -1, 1}, {-1, -1, -1}};
  for (std::size_t r = 0; r < 8; ++r) {
    data.at(r, 0) = 4.0f * signs[r][0] + 10.0f;
    data.at(r, 1) = 2.0f * signs[r][1];
    data.at(r, 2) = 1.0f * signs[r][2] - 3.0f;
  }
  auto pca = fit_pca(data);
  REQUIRE(pca);
  REQUIRE(pca->rank == 3);
  CHECK(pca->energy[0] == doctest::Approx(8 * 16.0));
  CHECK(pca->energy[1] == doctest::Approx(8 * 4.0));
  CHECK(pca->energy[2] == doctest::Approx(8 * 1.0));
  CHECK(pca->energy_fraction(1) == doctest::Approx(16.0 / 21.0));
  CHECK(pca->energy_fraction(2) == doctest::Approx(20.0 / 21.0));
  CHECK(std::abs(pca->basis.at(0, 0)) == doctest::Approx(1.0f));
  CHECK(pca->mean[0] == doctest::Approx(10.0f));
  CHECK(pca->mean[2] == doctest::Approx(-3.0f));
  CHECK(components_for_energy(*pca, 0.5) == 1);
  CHECK(components_for_energy(*pca, 0.9) == 2);
  CHECK(components_for_energy(*pca, 0.99) == 3);
  CHECK(components_for_energy(*pca, 0.0) == 0);
  auto by_energy = fit_pca(data, {.energy_fraction = 0.9});
  REQUIRE(by_energy);
  CHECK(by_energy->components() == 2);
  auto by_count = fit_pca(data, {.max_components = 1});
  REQUIRE(by_count);
  CHECK(by_count->components() == 1);
  auto both = fit_pca(data, {.max_components = 1, .energy_fraction = 0.99});
  REQUIRE(both);
  CHECK(both->components() == 1);
}

TEST_CASE("PCA with m = 0 reconstructs the mean; full rank reconstructs exactly") {
  for (auto [rows, cols] : {std::pair<std::size_t, std::size_t>{30, 12}, {9, 64}}) {
    const Matrix data = random_matrix(rows, cols, 7);
    auto none = fit_pca(data, {.max_components = 0});
    REQUIRE(none);
    CHECK(none->components() == 0);
    const Matrix mean_only = reconstruct(*none, project(*none, data));
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c = 0; c < cols; ++c) REQUIRE(mean_only.at(r, c) == doctest::Approx(none->mean[c]));
    auto full = fit_pca(data);
    REQUIRE(full);
    CHECK(full->rank == std::min(rows - 1, cols));  // centring removes one dimension
    CHECK(max_abs_difference(reconstruct(*full, project(*full, data)), data) < 1e-5);
    auto raw = fit_pca(data, {.center = false});
    REQUIRE(raw);
    CHECK(raw->rank == std::min(rows, cols));
    CHECK(max_abs_difference(reconstruct(*raw, project(*raw, data)), data) < 1e-5);
  }
}

TEST_CASE("PCA extremes: constant data, one row, bad input") {
  Matrix constant(5, 4, 2.5f);
  auto pca = fit_pca(constant);
  REQUIRE(pca);
  CHECK(pca->rank == 0);
  CHECK(pca->energy_fraction(0) == 1.0);
  CHECK(max_abs_difference(reconstruct(*pca, project(*pca, constant)), constant) == 0.0);
  auto one = fit_pca(random_matrix(1, 6, 3), {.center = false});
  REQUIRE(one);
  CHECK(one->rank == 1);
  CHECK_FALSE(fit_pca(Matrix{}));
  Matrix bad = random_matrix(3, 3, 1);
  bad.at(1, 2) = std::numeric_limits<float>::quiet_NaN();
  auto e = fit_pca(bad);
  REQUIRE_FALSE(e);
  CHECK(e.error().message.find("row 1, column 2") != std::string::npos);
  CHECK_FALSE(fit_pca(random_matrix(3, 3, 1), {.energy_fraction = 1.5}));
}

TEST_CASE("k-means separates well-separated blobs with both seedings") {
  Matrix points(60, 2);
  for (std::size_t i = 0; i < 60; ++i) {
    const float cx = float(i % 3) * 100.0f, jitter = float(i) * 0.01f;
    points.at(i, 0) = cx + jitter;
    points.at(i, 1) = -cx + jitter;
  }
  for (Seeding seeding : {Seeding::KMeansPlusPlus, Seeding::FarthestPoint}) {
    CAPTURE(to_string(seeding));
    auto result = kmeans(points, {.k = 3, .seeding = seeding, .seed = 42});
    REQUIRE(result);
    CHECK(result->converged);
    for (std::size_t i = 3; i < 60; ++i) CHECK(result->labels[i] == result->labels[i % 3]);
    CHECK(result->sizes[0] == 20);
    CHECK(result->inertia < 60.0 * 1.0);
  }
}

TEST_CASE("k-means at k = 1 and k = number of points") {
  const Matrix points = random_matrix(25, 3, 11);
  for (Seeding seeding : {Seeding::KMeansPlusPlus, Seeding::FarthestPoint}) {
    auto one = kmeans(points, {.k = 1, .seeding = seeding});
    REQUIRE(one);
    CHECK(one->converged);
    for (auto l : one->labels) CHECK(l == 0);
    for (std::size_t c = 0; c < 3; ++c) {
      double mean = 0.0;
      for (std::size_t i = 0; i < 25; ++i) mean += points.at(i, c);
      CHECK(one->centers.at(0, c) == doctest::Approx(mean / 25.0).epsilon(1e-5));
    }
    auto all = kmeans(points, {.k = 25, .seeding = seeding});
    REQUIRE(all);
    CHECK(all->inertia == 0.0);
    CHECK(std::set<std::uint32_t>(all->labels.begin(), all->labels.end()).size() == 25);
  }
  CHECK_FALSE(kmeans(points, {.k = 26}));
  CHECK_FALSE(kmeans(points, {.k = 0}));
  CHECK_FALSE(kmeans(Matrix{}, {.k = 1}));
}

TEST_CASE("k-means on duplicate points (every D² zero): no NaN, no hang") {
  Matrix same(12, 4, 3.0f);
  for (Seeding seeding : {Seeding::KMeansPlusPlus, Seeding::FarthestPoint}) {
    for (std::size_t k : {1u, 5u, 12u}) {
      auto result = kmeans(same, {.k = k, .seeding = seeding, .seed = 5});
      REQUIRE(result);
      CHECK(result->converged);
      CHECK(result->inertia == 0.0);
      for (float v : result->centers.values) CHECK(v == 3.0f);
      for (auto l : result->labels) CHECK(l < k);
    }
  }
  // Two distinct values, six copies each, k = 4: two clusters keep the points, two stay empty.
  Matrix pairs(12, 1);
  for (std::size_t i = 0; i < 12; ++i) pairs.at(i, 0) = i % 2 ? 1.0f : -1.0f;
  auto result = kmeans(pairs, {.k = 4});
  REQUIRE(result);
  CHECK(result->inertia == 0.0);
  std::size_t non_empty = 0;
  for (auto s : result->sizes) non_empty += s > 0;
  CHECK(non_empty == 2);
}

TEST_CASE("k-means is deterministic for a seed and independent of the thread count") {
  const Matrix points = random_matrix(500, 5, 99);
  for (Seeding seeding : {Seeding::KMeansPlusPlus, Seeding::FarthestPoint}) {
    auto a = kmeans(points, {.k = 12, .seeding = seeding, .seed = 7, .threads = 1});
    auto b = kmeans(points, {.k = 12, .seeding = seeding, .seed = 7, .threads = 4});
    REQUIRE(a);
    REQUIRE(b);
    CHECK(a->labels == b->labels);
    CHECK(a->centers.values == b->centers.values);
    CHECK(a->iterations == b->iterations);
  }
  auto s1 = seed_centers(points, 12, Seeding::KMeansPlusPlus, 1);
  auto s2 = seed_centers(points, 12, Seeding::KMeansPlusPlus, 2);
  REQUIRE(s1);
  REQUIRE(s2);
  CHECK(s1->values != s2->values);
}

TEST_CASE("fp16 conversion") {
  for (float v : {0.0f, 1.0f, -2.5f, 65504.0f, 0.000061035156f, 5.96046448e-8f, 3.14159f}) {
    CAPTURE(v);
    CHECK(half_to_float(float_to_half(v)) == doctest::Approx(v).epsilon(1e-3));
  }
  CHECK(float_to_half(1.0f) == 0x3c00);
  CHECK(float_to_half(-2.0f) == 0xc000);
  CHECK(std::isinf(half_to_float(float_to_half(1e6f))));
  CHECK(std::isnan(half_to_float(float_to_half(std::numeric_limits<float>::quiet_NaN()))));
  CHECK(float_to_half(1.0f + 0x1.0p-11f) == 0x3c00);  // halfway: to even
  CHECK(float_to_half(1.0f + 3 * 0x1.0p-11f) == 0x3c02);
}

TEST_CASE("CPCA: full rank is exact, stopping rules per cluster, quantized formats are bounded") {
  const Matrix data = random_matrix(90, 40, 5);
  std::vector<std::uint32_t> labels(90);
  for (std::size_t i = 0; i < 90; ++i) labels[i] = static_cast<std::uint32_t>(i % 4);  // cluster 3: 22 rows
  for (bool center : {true, false}) {
    auto full = compress(data, labels, 5, {.center = center});  // cluster 4 empty
    REQUIRE(full);
    CHECK(full->clusters[4].rows.empty());
    CHECK(max_abs_difference(reconstruct(*full), data) < 1e-5);
    auto none = compress(data, labels, 5, {.max_components = 0, .center = center});
    REQUIRE(none);
    CHECK(none->total_components() == 0);
    auto by_energy = compress(data, labels, 5, {.energy_fraction = 0.5, .center = center});
    REQUIRE(by_energy);
    for (const auto& c : by_energy->clusters)
      if (!c.rows.empty()) CHECK(c.basis.rows < c.rows.size());
    CHECK(by_energy->compressed_bytes() < full->compressed_bytes());
  }
  auto reference = compress(data, labels, 4, {});
  REQUIRE(reference);
  const Matrix exact = reconstruct(*reference);
  for (CoefficientFormat format : {CoefficientFormat::Float16, CoefficientFormat::Unorm8}) {
    auto q = compress(data, labels, 4, {.coefficients = format, .threads = 3});
    REQUIRE(q);
    const double error = max_abs_difference(reconstruct(*q), exact);
    CAPTURE(to_string(format));
    CHECK(error < (format == CoefficientFormat::Float16 ? 5e-3 : 0.1));
    CHECK(q->compressed_bytes() < reference->compressed_bytes());
  }
  auto half = compress(data, labels, 4, {.half_basis = true});
  REQUIRE(half);
  CHECK(max_abs_difference(reconstruct(*half), exact) < 5e-3);
  CHECK(half->compressed_bytes() < reference->compressed_bytes());
  for (const auto& c : half->clusters)
    for (float v : c.basis.values) CHECK(half_to_float(float_to_half(v)) == v);
  // One row per cluster (k = rows): every row is its cluster's mean.
  std::vector<std::uint32_t> own(90);
  for (std::size_t i = 0; i < 90; ++i) own[i] = static_cast<std::uint32_t>(i);
  auto singletons = compress(data, own, 90, {});
  REQUIRE(singletons);
  CHECK(singletons->total_components() == 0);
  CHECK(max_abs_difference(reconstruct(*singletons), data) == 0.0);
  std::vector<std::uint32_t> bad(90, 0);
  bad[10] = 9;
  CHECK_FALSE(compress(data, bad, 4, {}));
  CHECK_FALSE(compress(data, std::vector<std::uint32_t>(3, 0), 4, {}));
}
