// Clustered PCA: one PCA per cluster of rows, coefficients quantized to the chosen format,
// and fp16 conversion. Clusters are compressed in parallel (each independent).
module;
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <vector>
module weft.cluster;
import weft.core;

namespace weft::cluster {

std::string_view to_string(CoefficientFormat format) {
  switch (format) {
    case CoefficientFormat::Float32: return "fp32";
    case CoefficientFormat::Float16: return "fp16";
    case CoefficientFormat::Unorm8: return "8-bit";
  }
  return "?";
}

std::size_t bytes_per_coefficient(CoefficientFormat format) {
  switch (format) {
    case CoefficientFormat::Float32: return 4;
    case CoefficientFormat::Float16: return 2;
    case CoefficientFormat::Unorm8: return 1;
  }
  return 4;
}

std::uint16_t float_to_half(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  const std::uint32_t sign = (bits >> 16) & 0x8000u;
  const std::uint32_t abs = bits & 0x7fffffffu;
  if (abs >= 0x7f800000u) return static_cast<std::uint16_t>(sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u : 0u));
  if (abs >= 0x477ff000u) return static_cast<std::uint16_t>(sign | 0x7c00u);  // rounds past 65504
  if (abs < 0x38800000u) {
    // Subnormal half (or zero): value * 2^24 rounded to nearest even.
    const float scaled = std::bit_cast<float>(abs) * 16777216.0f;
    return static_cast<std::uint16_t>(sign | static_cast<std::uint32_t>(std::nearbyint(scaled)));
  }
  std::uint32_t h = ((abs - 0x38000000u) >> 13);
  const std::uint32_t rest = abs & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (h & 1u))) ++h;
  return static_cast<std::uint16_t>(sign | h);
}

float half_to_float(std::uint16_t half) {
  const std::uint32_t sign = (std::uint32_t(half) & 0x8000u) << 16;
  const std::uint32_t exponent = (half >> 10) & 0x1fu, mantissa = half & 0x3ffu;
  if (exponent == 0) {
    const float v = float(mantissa) * 0x1.0p-24f;
    return sign ? -v : v;
  }
  if (exponent == 31) return std::bit_cast<float>(sign | 0x7f800000u | (mantissa << 13));
  return std::bit_cast<float>(sign | ((exponent + 112u) << 23) | (mantissa << 13));
}

std::size_t Cpca::total_components() const {
  std::size_t sum = 0;
  for (const auto& c : clusters) sum += c.basis.rows;
  return sum;
}

std::size_t Cpca::compressed_bytes() const {
  std::size_t bytes = row_count * 2 * sizeof(std::uint32_t);
  for (const auto& c : clusters) {
    bytes += (c.mean.size() + c.basis.values.size()) * (half_basis ? 2 : 4);
    bytes += c.coefficients.values.size() * bytes_per_coefficient(format);
    bytes += (c.offset.size() + c.scale.size()) * sizeof(float);
  }
  return bytes;
}

namespace {
void quantize(CpcaCluster& cluster, CoefficientFormat format) {
  auto& a = cluster.coefficients;
  if (format == CoefficientFormat::Float16) {
    for (float& v : a.values) v = half_to_float(float_to_half(v));
  } else if (format == CoefficientFormat::Unorm8) {
    cluster.offset.assign(a.cols, 0.0f);
    cluster.scale.assign(a.cols, 0.0f);
    for (std::size_t k = 0; k < a.cols; ++k) {
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (std::size_t r = 0; r < a.rows; ++r) lo = std::min(lo, a.at(r, k)), hi = std::max(hi, a.at(r, k));
      const float scale = hi > lo ? (hi - lo) / 255.0f : 0.0f;
      cluster.offset[k] = lo;
      cluster.scale[k] = scale;
      for (std::size_t r = 0; r < a.rows; ++r) {
        const float q = scale > 0.0f ? std::clamp(std::round((a.at(r, k) - lo) / scale), 0.0f, 255.0f) : 0.0f;
        a.at(r, k) = lo + scale * q;
      }
    }
  }
}
}  // namespace

Result<Cpca> compress(const Matrix& data, std::span<const std::uint32_t> labels, std::size_t cluster_count,
                      const CpcaOptions& options) {
  if (labels.size() != data.rows)
    return fail(ErrorKind::InvalidArgument, "CPCA: {} labels for {} rows", labels.size(), data.rows);
  if (data.values.size() != data.rows * data.cols)
    return fail(ErrorKind::InvalidArgument, "CPCA: matrix holds {} values, not {} x {}", data.values.size(), data.rows,
                data.cols);
  Cpca cpca;
  cpca.cols = data.cols;
  cpca.row_count = data.rows;
  cpca.format = options.coefficients;
  cpca.half_basis = options.half_basis;
  cpca.clusters.resize(cluster_count);
  cpca.cluster_of.assign(labels.begin(), labels.end());
  cpca.slot_of.assign(data.rows, 0);
  for (std::size_t r = 0; r < data.rows; ++r) {
    if (labels[r] >= cluster_count)
      return fail(ErrorKind::InvalidArgument, "CPCA: row {} has label {}, but there are {} clusters", r, labels[r],
                  cluster_count);
    auto& rows = cpca.clusters[labels[r]].rows;
    cpca.slot_of[r] = static_cast<std::uint32_t>(rows.size());
    rows.push_back(static_cast<std::uint32_t>(r));
  }

  std::mutex error_mutex;
  std::optional<Error> first_error;
  const auto start = std::chrono::steady_clock::now();
  std::size_t done = 0;
  parallel_each(cluster_count, options.threads, [&](std::size_t c) {
    auto& cluster = cpca.clusters[c];
    if (cluster.rows.empty()) return;
    Matrix block(cluster.rows.size(), data.cols);
    for (std::size_t i = 0; i < cluster.rows.size(); ++i)
      std::ranges::copy(data.row(cluster.rows[i]), block.row(i).begin());
    auto pca = fit_pca(block, {.max_components = options.max_components,
                               .energy_fraction = options.energy_fraction,
                               .center = options.center});
    if (!pca) {
      std::scoped_lock lock(error_mutex);
      if (!first_error) first_error = pca.error();
      return;
    }
    cluster.coefficients = project(*pca, block);
    if (options.center) cluster.mean = pca->mean;
    cluster.basis = std::move(pca->basis);
    quantize(cluster, options.coefficients);
    if (options.half_basis) {
      // Coefficients were projected on the fp32 basis; with basis rows orthonormal, the
      // rounding shows as an error of about 2^-11 relative per basis value.
      for (float& v : cluster.basis.values) v = half_to_float(float_to_half(v));
      for (float& v : cluster.mean) v = half_to_float(float_to_half(v));
    }
    std::scoped_lock lock(error_mutex);
    ++done;
    if (data.values.size() > (1u << 22) && cluster_count >= 16 && done % (cluster_count / 8) == 0)
      log::info(weft::format("CPCA: {}/{} clusters, {:.1f} s", done, cluster_count,
                             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
  });
  if (first_error) return with_context("CPCA", *first_error);
  return cpca;
}

void reconstruct_row(const Cpca& cpca, std::size_t row, std::span<float> out) {
  const auto& cluster = cpca.clusters[cpca.cluster_of[row]];
  const std::size_t slot = cpca.slot_of[row];
  for (std::size_t j = 0; j < cpca.cols; ++j) out[j] = cluster.mean.empty() ? 0.0f : cluster.mean[j];
  for (std::size_t k = 0; k < cluster.basis.rows; ++k) {
    const float a = cluster.coefficients.at(slot, k);
    const auto b = cluster.basis.row(k);
    for (std::size_t j = 0; j < cpca.cols; ++j) out[j] += a * b[j];
  }
}

Matrix reconstruct(const Cpca& cpca) {
  Matrix out(cpca.row_count, cpca.cols);
  for (std::size_t r = 0; r < cpca.row_count; ++r) reconstruct_row(cpca, r, out.row(r));
  return out;
}

}  // namespace weft::cluster
