// The paper's ABRDF clustering: PCA of the preprocessed ABRDFs (fitted on a seeded sample of
// texels, then every texel projected), k-means on the coefficients (weft.cluster), and per
// cluster the element-wise median of its members' raw ABRDFs plus the medoid texel. Clusters
// that k-means leaves empty (only possible with duplicate ABRDFs) are dropped and the ids
// renumbered, so every cluster has a median of real members.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <numeric>
#include <random>
#include <span>
#include <vector>
#include <weft/try.h>
module weft.btf;
import weft.cluster;

namespace weft::btf {
namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

Result<Clustering> cluster_abrdfs(const Btf& btf, const ClusterOptions& o) {
  WEFT_TRY_VOID(validate(btf, "clustering"));
  const std::size_t texels = btf.texels(), n = btf.abrdf_floats();
  if (o.clusters == 0 || o.clusters > texels)
    return fail(ErrorKind::InvalidArgument, "clustering: {} clusters must be in [1, {}] (the texel count)", o.clusters, texels);
  if (o.pca_components == 0)
    return fail(ErrorKind::InvalidArgument, "clustering: pca_components must be at least 1");
  const auto start = std::chrono::steady_clock::now();
  const bool verbose = double(texels) * double(n) > 2e7;
  const Preprocessing constants = preprocessing_constants(btf);

  // PCA on a seeded sample of texels (sorted, so the matrix does not depend on draw order).
  std::vector<std::uint32_t> sample(texels);
  std::iota(sample.begin(), sample.end(), 0u);
  if (o.pca_sample_texels != 0 && o.pca_sample_texels < texels) {
    std::mt19937_64 rng(o.seed ^ 0x5ca1ab1eull);
    for (std::size_t i = 0; i < o.pca_sample_texels; ++i) {  // partial Fisher-Yates
      const std::size_t j = i + std::size_t((rng() >> 11) % (texels - i));
      std::swap(sample[i], sample[j]);
    }
    sample.resize(o.pca_sample_texels);
    std::ranges::sort(sample);
  }
  cluster::Matrix fit(sample.size(), n);
  cluster::parallel_for(sample.size(), o.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) preprocess_input(constants, btf.abrdf(sample[i]), fit.row(i));
  });
  cluster::PcaOptions pca_options;
  pca_options.max_components = o.pca_components;
  auto pca = cluster::fit_pca(fit, pca_options);
  if (!pca) return with_context("clustering: PCA", pca.error());
  fit = {};
  const std::size_t m = pca->components();
  if (verbose)
    log::info(weft::format("clustering: PCA of {} sampled texels x {} dimensions, {} components ({:.1f} % energy), {:.1f} s",
                           sample.size(), n, m, 100.0 * pca->energy_fraction(m), seconds_since(start)));

  // Coefficients of every texel; with rank 0 (every ABRDF the same) one zero column, so
  // k-means still sees the points (all duplicates).
  // Also the energy of every texel's centred row and of its projection: the fraction of
  // all texels' energy the sampled basis holds (an honest figure for the sampling).
  cluster::Matrix coefficients(texels, std::max<std::size_t>(m, 1));
  std::vector<double> energy(texels, 0.0), kept(texels, 0.0);
  cluster::parallel_for(texels, o.threads, [&](std::size_t begin, std::size_t end) {
    std::vector<float> row(n);
    for (std::size_t t = begin; t < end; ++t) {
      preprocess_input(constants, btf.abrdf(t), row);
      double e = 0.0;
      for (std::size_t d = 0; d < n; ++d) {
        row[d] -= pca->mean[d];
        e += double(row[d]) * row[d];
      }
      energy[t] = e;
      for (std::size_t k = 0; k < m; ++k) {
        const auto basis = pca->basis.row(k);
        double dot = 0.0;
        for (std::size_t d = 0; d < n; ++d) dot += double(row[d]) * double(basis[d]);
        coefficients.at(t, k) = static_cast<float>(dot);
        kept[t] += dot * dot;
      }
    }
  });
  double total_energy = 0.0, kept_energy = 0.0;
  for (std::size_t t = 0; t < texels; ++t) total_energy += energy[t], kept_energy += kept[t];

  cluster::KMeansOptions km;
  km.k = o.clusters;
  km.seeding = o.seeding == ClusterSeeding::FarthestPoint ? cluster::Seeding::FarthestPoint : cluster::Seeding::KMeansPlusPlus;
  km.seed = o.seed;
  km.max_iterations = o.max_iterations;
  km.threads = o.threads;
  auto means = cluster::kmeans(coefficients, km);
  if (!means) return with_context("clustering: k-means", means.error());
  if (verbose)
    log::info(weft::format("clustering: k-means k = {} on {} x {} coefficients, {} iterations{}, {:.1f} s", o.clusters, texels,
                           coefficients.cols, means->iterations, means->converged ? " (converged)" : "", seconds_since(start)));

  // Drop empty clusters, keeping k-means' order.
  std::vector<std::uint32_t> renumber(o.clusters, std::numeric_limits<std::uint32_t>::max());
  Clustering out;
  for (std::size_t c = 0; c < o.clusters; ++c)
    if (means->sizes[c] != 0) {
      renumber[c] = out.count();
      out.sizes.push_back(static_cast<std::uint32_t>(means->sizes[c]));
      out.medoids.push_back(0);
    }
  const std::size_t k = out.count();
  out.ids.resize(texels);
  std::vector<std::vector<std::uint32_t>> members(k);
  for (std::size_t t = 0; t < texels; ++t) {
    out.ids[t] = renumber[means->labels[t]];
    members[out.ids[t]].push_back(static_cast<std::uint32_t>(t));
  }
  out.pca_components = static_cast<std::uint32_t>(m);
  out.pca_energy = total_energy > 0.0 ? std::min(1.0, kept_energy / total_energy) : 1.0;
  out.iterations = means->iterations;

  // Element-wise median (the mean of the two middle values for an even count), then the
  // member nearest to it (ties: the lowest texel).
  out.medians.assign(k * n, 0.0f);
  cluster::parallel_each(k, o.threads, [&](std::size_t c) {
    const auto& ms = members[c];
    std::vector<float> values(ms.size());
    float* median = out.medians.data() + c * n;
    for (std::size_t d = 0; d < n; ++d) {
      for (std::size_t i = 0; i < ms.size(); ++i) values[i] = btf.rgb[std::size_t(ms[i]) * n + d];
      const std::size_t mid = values.size() / 2;
      std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(mid), values.end());
      float v = values[mid];
      if (values.size() % 2 == 0) {
        const float lower = *std::max_element(values.begin(), values.begin() + std::ptrdiff_t(mid));
        v = static_cast<float>(0.5 * (double(lower) + double(v)));
      }
      median[d] = v;
    }
    double best = std::numeric_limits<double>::infinity();
    for (auto t : ms) {
      const auto a = btf.abrdf(t);
      double dist = 0.0;
      for (std::size_t d = 0; d < n; ++d) {
        const double e = double(a[d]) - double(median[d]);
        dist += e * e;
      }
      if (dist < best) best = dist, out.medoids[c] = t;
    }
  });
  if (verbose)
    log::info(weft::format("clustering: {} clusters, medians and medoids, {:.1f} s total", k, seconds_since(start)));
  return out;
}

}  // namespace weft::btf
