// CPCA of a mesh's SSDFs: k-means over triangle centroids, a vertex to the cluster most of
// its triangles are in, weft.cluster's compressor; and the error of a reconstruction.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <map>
#include <mutex>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;

namespace weft::ssdf {

Result<Compressed> compress(const BakeMesh& mesh, const cluster::Matrix& ssdf, const CompressOptions& options) {
  if (ssdf.rows != mesh.vertex_count())
    return fail(ErrorKind::InvalidArgument, "SSDF compression: {} SSDF rows for {} vertices", ssdf.rows,
                mesh.vertex_count());
  Compressed result;
  const std::size_t triangles = mesh.triangle_count();
  std::vector<std::uint32_t> vertex_cluster(mesh.vertex_count(), 0);
  std::size_t k = 1;
  if (triangles > 0) {
    k = std::clamp<std::size_t>(options.clusters, 1, triangles);
    cluster::Matrix centroids(triangles, 3);
    for (std::size_t t = 0; t < triangles; ++t) {
      const vec3 c = (mesh.positions[mesh.indices[3 * t]] + mesh.positions[mesh.indices[3 * t + 1]] +
                      mesh.positions[mesh.indices[3 * t + 2]]) / 3.0f;
      for (int a = 0; a < 3; ++a) centroids.at(t, std::size_t(a)) = c[a];
    }
    auto clusters = cluster::kmeans(centroids, {.k = k, .seeding = options.seeding, .seed = options.seed,
                                                .threads = options.threads});
    if (!clusters) return with_context("SSDF compression", clusters.error());
    result.triangle_cluster = std::move(clusters->labels);
    // Majority vote of each vertex's triangles (ties: the lower cluster id).
    std::vector<std::map<std::uint32_t, std::uint32_t>> votes(mesh.vertex_count());
    for (std::size_t t = 0; t < triangles; ++t)
      for (int c = 0; c < 3; ++c) ++votes[mesh.indices[3 * t + std::size_t(c)]][result.triangle_cluster[t]];
    for (std::size_t v = 0; v < votes.size(); ++v) {
      std::uint32_t best = 0, count = 0;
      for (auto [id, n] : votes[v])
        if (n > count) best = id, count = n;
      vertex_cluster[v] = best;
    }
  }
  auto cpca = cluster::compress(ssdf, vertex_cluster, k,
                                {.max_components = options.max_components,
                                 .energy_fraction = options.energy_fraction,
                                 .center = options.center,
                                 .coefficients = options.coefficients,
                                 .half_basis = options.half_basis,
                                 .threads = options.threads});
  if (!cpca) return with_context("SSDF compression", cpca.error());
  result.cpca = std::move(*cpca);
  return result;
}

namespace {
struct ErrorSums {
  double squared = 0.0, max_abs = 0.0;
  std::size_t sign_errors = 0;
  void add(float raw, float approximation) {
    const double e = double(approximation) - double(raw);
    squared += e * e;
    max_abs = std::max(max_abs, std::abs(e));
    sign_errors += (raw > 0.0f) != (approximation > 0.0f);
  }
  void merge(const ErrorSums& o) {
    squared += o.squared;
    max_abs = std::max(max_abs, o.max_abs);
    sign_errors += o.sign_errors;
  }
  [[nodiscard]] ErrorStats stats(std::size_t count) const {
    if (count == 0) return {};
    return {std::sqrt(squared / double(count)), double(sign_errors) / double(count), max_abs};
  }
};
}  // namespace

ErrorStats measure_error(const cluster::Matrix& raw, const cluster::Cpca& cpca, std::size_t threads) {
  std::mutex mutex;
  ErrorSums total;
  // Fixed chunks merged in chunk order would still vary in rounding with the thread count;
  // RMSE is a report, not a result, so a mutex-merged sum is fine.
  cluster::parallel_for(raw.rows, threads, [&](std::size_t begin, std::size_t end) {
    ErrorSums sums;
    std::vector<float> row(raw.cols);
    for (std::size_t r = begin; r < end; ++r) {
      cluster::reconstruct_row(cpca, r, row);
      const auto original = raw.row(r);
      for (std::size_t c = 0; c < raw.cols; ++c) sums.add(original[c], row[c]);
    }
    std::scoped_lock lock(mutex);
    total.merge(sums);
  });
  return total.stats(raw.values.size());
}

ErrorStats measure_error(const cluster::Matrix& raw, const cluster::Matrix& approximation) {
  ErrorSums sums;
  for (std::size_t i = 0; i < std::min(raw.values.size(), approximation.values.size()); ++i)
    sums.add(raw.values[i], approximation.values[i]);
  return sums.stats(raw.values.size());
}

}  // namespace weft::ssdf
