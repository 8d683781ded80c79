// k-means: k-means++ (D²) or farthest-point seeding, then Lloyd iterations. Deterministic:
// a fixed-seed mt19937_64 with our own uniform draw, assignment in parallel (each point
// independent), centre updates serial in point order.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <random>
#include <span>
#include <string_view>
#include <vector>
module weft.cluster;
import weft.core;

namespace weft::cluster {
namespace {
double squared_distance(std::span<const float> a, std::span<const float> b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double t = double(a[i]) - double(b[i]);
    sum += t * t;
  }
  return sum;
}

// A uniform double in [0, 1) from the top 53 bits: the same on every standard library.
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

Result<void> check_points(const Matrix& points, std::size_t k) {
  if (points.rows == 0 || points.cols == 0)
    return fail(ErrorKind::InvalidArgument, "k-means of an empty point set ({} x {})", points.rows, points.cols);
  if (points.values.size() != points.rows * points.cols)
    return fail(ErrorKind::InvalidArgument, "k-means: matrix holds {} values, not {} x {}", points.values.size(),
                points.rows, points.cols);
  if (k == 0 || k > points.rows)
    return fail(ErrorKind::InvalidArgument, "k-means: k = {} must be in [1, {}] (the number of points)", k, points.rows);
  for (std::size_t i = 0; i < points.values.size(); ++i)
    if (!std::isfinite(points.values[i]))
      return fail(ErrorKind::InvalidArgument, "k-means: non-finite value at point {}, dimension {}", i / points.cols,
                  i % points.cols);
  return {};
}
}  // namespace

std::string_view to_string(Seeding seeding) {
  return seeding == Seeding::KMeansPlusPlus ? "k-means++" : "farthest-point";
}

Result<Matrix> seed_centers(const Matrix& points, std::size_t k, Seeding seeding, std::uint64_t seed) {
  if (auto ok = check_points(points, k); !ok) return std::unexpected(ok.error());
  std::mt19937_64 rng(seed);
  Matrix centers(k, points.cols);
  std::vector<double> d2(points.rows, std::numeric_limits<double>::infinity());
  std::vector<bool> chosen(points.rows, false);
  std::size_t pick = std::min<std::size_t>(points.rows - 1, static_cast<std::size_t>(uniform(rng) * double(points.rows)));
  for (std::size_t c = 0;; ++c) {
    chosen[pick] = true;
    std::ranges::copy(points.row(pick), centers.row(c).begin());
    if (c + 1 == k) break;
    double total = 0.0, farthest = -1.0;
    std::size_t farthest_index = 0;
    for (std::size_t i = 0; i < points.rows; ++i) {
      d2[i] = std::min(d2[i], squared_distance(points.row(i), centers.row(c)));
      total += d2[i];
      if (!chosen[i] && d2[i] > farthest) farthest = d2[i], farthest_index = i;
    }
    if (seeding == Seeding::FarthestPoint || total <= 0.0) {
      // Farthest point; with every D² zero (duplicates) the first point not chosen yet.
      pick = farthest_index;
      continue;
    }
    const double target = uniform(rng) * total;
    double running = 0.0;
    pick = farthest_index;  // guards against rounding at the end of the running sum
    for (std::size_t i = 0; i < points.rows; ++i) {
      if (d2[i] <= 0.0) continue;
      running += d2[i];
      if (running > target) {
        pick = i;
        break;
      }
    }
  }
  return centers;
}

Result<KMeans> kmeans(const Matrix& points, const KMeansOptions& options) {
  auto seeded = seed_centers(points, options.k, options.seeding, options.seed);
  if (!seeded) return std::unexpected(seeded.error());
  const std::size_t k = options.k, n = points.rows, dims = points.cols;
  KMeans result;
  result.centers = std::move(*seeded);
  result.labels.assign(n, 0);
  std::vector<double> distance(n, 0.0);
  const bool verbose = double(n) * double(k) * double(dims) > 5e7;
  const auto start = std::chrono::steady_clock::now();

  auto assign = [&] {
    std::vector<std::uint8_t> changed_chunk(n, 0);
    parallel_for(n, options.threads, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        double best = std::numeric_limits<double>::infinity();
        std::uint32_t label = 0;
        for (std::size_t c = 0; c < k; ++c) {
          const double d = squared_distance(points.row(i), result.centers.row(c));
          if (d < best) best = d, label = static_cast<std::uint32_t>(c);
        }
        changed_chunk[i] = label != result.labels[i];
        result.labels[i] = label;
        distance[i] = best;
      }
    });
    return std::ranges::count(changed_chunk, std::uint8_t{1});
  };

  std::ptrdiff_t changed = assign();
  for (result.iterations = 0; result.iterations < options.max_iterations;) {
    // Update: means in double, serial in point order.
    std::vector<double> sums(k * dims, 0.0);
    result.sizes.assign(k, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto row = points.row(i);
      double* sum = sums.data() + result.labels[i] * dims;
      for (std::size_t j = 0; j < dims; ++j) sum[j] += row[j];
      ++result.sizes[result.labels[i]];
    }
    for (std::size_t c = 0; c < k; ++c) {
      if (result.sizes[c] == 0) continue;
      for (std::size_t j = 0; j < dims; ++j)
        result.centers.at(c, j) = static_cast<float>(sums[c * dims + j] / double(result.sizes[c]));
    }
    // Empty clusters take the worst-fitting point of a cluster that can spare one.
    for (std::size_t c = 0; c < k; ++c) {
      if (result.sizes[c] != 0) continue;
      double worst = 0.0;
      std::size_t worst_index = n;
      for (std::size_t i = 0; i < n; ++i)
        if (result.sizes[result.labels[i]] > 1 && distance[i] > worst) worst = distance[i], worst_index = i;
      if (worst_index == n) continue;  // only duplicates left: the cluster stays empty
      --result.sizes[result.labels[worst_index]];
      result.labels[worst_index] = static_cast<std::uint32_t>(c);
      result.sizes[c] = 1;
      distance[worst_index] = 0.0;
      std::ranges::copy(points.row(worst_index), result.centers.row(c).begin());
    }
    ++result.iterations;
    changed = assign();
    if (verbose)
      log::info(weft::format("k-means ({}, k = {}): iteration {}, {} labels changed, {:.1f} s", to_string(options.seeding),
                             k, result.iterations, changed,
                             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
    if (changed == 0) {
      result.converged = true;
      break;
    }
  }
  result.sizes.assign(k, 0);
  result.inertia = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    ++result.sizes[result.labels[i]];
    result.inertia += distance[i];
  }
  return result;
}

}  // namespace weft::cluster
