// weft.cluster — dimensionality reduction and clustering for baked data: PCA (exact rank,
// m-component or energy-fraction stopping), k-means with k-means++ (D²) or farthest-point
// seeding, and the clustered-PCA (CPCA) compressor with optional mean-centering and
// fp16/8-bit coefficients. Pure and deterministic (fixed seeds; results do not depend on
// the thread count); shared by the SSDF bake and the neural BTF.
module;
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <string_view>
#include <vector>
export module weft.cluster;
import weft.core;

export namespace weft::cluster {

// A dense row-major matrix: one row per sample (point, vertex, texel), one column per
// dimension.
struct Matrix {
  std::size_t rows = 0;
  std::size_t cols = 0;
  std::vector<float> values;  // rows * cols

  Matrix() = default;
  Matrix(std::size_t r, std::size_t c, float fill = 0.0f) : rows(r), cols(c), values(r * c, fill) {}
  [[nodiscard]] float& at(std::size_t r, std::size_t c) { return values[r * cols + c]; }
  [[nodiscard]] float at(std::size_t r, std::size_t c) const { return values[r * cols + c]; }
  [[nodiscard]] std::span<float> row(std::size_t r) { return {values.data() + r * cols, cols}; }
  [[nodiscard]] std::span<const float> row(std::size_t r) const { return {values.data() + r * cols, cols}; }
};

// Runs body(begin, end) over contiguous chunks of [0, count) on `threads` std::threads
// (0 = hardware concurrency; 1 or a small count runs inline). Each call must write only to
// its own range, so results never depend on the thread count.
void parallel_for(std::size_t count, std::size_t threads, const std::function<void(std::size_t, std::size_t)>& body);
// Runs body(i) for every i in [0, count), handing indices out one at a time (for uneven
// work such as clusters of different sizes).
void parallel_each(std::size_t count, std::size_t threads, const std::function<void(std::size_t)>& body);

// ---- PCA -------------------------------------------------------------------------------

// Which components to keep: at most `max_components`, and no more than the fewest whose
// energy (sum of squared singular values of the (centred) data) reaches `energy_fraction`
// of the total. Defaults keep the full rank.
struct PcaOptions {
  std::size_t max_components = std::numeric_limits<std::size_t>::max();
  double energy_fraction = 1.0;  // in [0, 1]
  bool center = true;            // subtract the mean row first (false: SVD of the raw data)
};

struct Pca {
  std::vector<float> mean;     // cols; all zero when not centred
  Matrix basis;                // components x cols, orthonormal rows, by decreasing energy
  std::vector<double> energy;  // squared singular value of every component of the exact
                               // rank (not only the kept ones), decreasing
  double total_energy = 0.0;   // sum of squares of the (centred) data
  std::size_t rank = 0;        // numerical rank of the (centred) data

  [[nodiscard]] std::size_t components() const { return basis.rows; }
  // Fraction of the total energy the first m components hold (1 for zero data).
  [[nodiscard]] double energy_fraction(std::size_t m) const;
};

// Rows << columns uses the eigen decomposition of the rows x rows Gram matrix, otherwise the
// cols x cols covariance (both in double). Zero rows: InvalidArgument. Non-finite values:
// InvalidArgument naming the row and column.
[[nodiscard]] Result<Pca> fit_pca(const Matrix& data, const PcaOptions& options = {});
// The smallest m whose energy fraction reaches `fraction`, at most the rank.
[[nodiscard]] std::size_t components_for_energy(const Pca& pca, double fraction);
// Coefficients (rows x components) of `data` in the basis, and back.
[[nodiscard]] Matrix project(const Pca& pca, const Matrix& data);
[[nodiscard]] Matrix reconstruct(const Pca& pca, const Matrix& coefficients);

// ---- k-means ---------------------------------------------------------------------------

enum class Seeding : std::uint8_t {
  KMeansPlusPlus,  // Arthur & Vassilvitskii: the next centre drawn with probability ∝ D²
  FarthestPoint,   // the SSDF paper's description: the next centre is the point with the
                   // largest D² (first centre drawn at random from the seed)
};
[[nodiscard]] std::string_view to_string(Seeding seeding);

struct KMeansOptions {
  std::size_t k = 8;
  Seeding seeding = Seeding::KMeansPlusPlus;
  std::uint64_t seed = 1;
  std::size_t max_iterations = 100;  // Lloyd iterations; stops earlier when no label changes
  std::size_t threads = 0;
};

struct KMeans {
  Matrix centers;                     // k x cols
  std::vector<std::uint32_t> labels;  // one per point, in [0, k)
  std::vector<std::size_t> sizes;     // points per cluster (0 only when there are fewer
                                      // distinct points than k)
  std::size_t iterations = 0;
  bool converged = false;
  double inertia = 0.0;               // sum of squared distances to the assigned centres
};

// Lloyd's algorithm after the chosen seeding. Ties go to the lowest centre index. A cluster
// that empties takes the point farthest from its centre among clusters with more than one
// point; with nothing left to take (duplicates) it stays empty. k > points or k = 0:
// InvalidArgument; non-finite values: InvalidArgument. Logs progress on long runs.
[[nodiscard]] Result<KMeans> kmeans(const Matrix& points, const KMeansOptions& options);
// Only the seeding (k x cols centres), for comparing seedings.
[[nodiscard]] Result<Matrix> seed_centers(const Matrix& points, std::size_t k, Seeding seeding, std::uint64_t seed);

// ---- clustered PCA ---------------------------------------------------------------------

enum class CoefficientFormat : std::uint8_t {
  Float32,
  Float16,  // IEEE half, round to nearest even
  Unorm8,   // per cluster and component: value = offset + scale * q, q in [0, 255]
};
[[nodiscard]] std::string_view to_string(CoefficientFormat format);
[[nodiscard]] std::size_t bytes_per_coefficient(CoefficientFormat format);

struct CpcaOptions {
  std::size_t max_components = std::numeric_limits<std::size_t>::max();  // per cluster
  double energy_fraction = 1.0;  // per cluster (the SSDF paper's 寄与率 90 %: 0.9)
  bool center = true;
  CoefficientFormat coefficients = CoefficientFormat::Float32;
  bool half_basis = false;  // round each cluster's mean and basis to fp16 (they dominate the
                            // size when rows per cluster are few)
  std::size_t threads = 0;
};

struct CpcaCluster {
  std::vector<std::uint32_t> rows;  // data rows of this cluster, ascending
  std::vector<float> mean;          // cols when centred, else empty
  Matrix basis;                     // components x cols
  Matrix coefficients;              // rows.size() x components, already quantized: the
                                    // values a decoder sees
  std::vector<float> offset, scale; // Unorm8: per component; else empty
};

struct Cpca {
  std::size_t cols = 0;
  std::size_t row_count = 0;
  CoefficientFormat format = CoefficientFormat::Float32;
  bool half_basis = false;  // means and bases hold fp16-representable values, stored as fp16
  std::vector<CpcaCluster> clusters;
  std::vector<std::uint32_t> cluster_of;  // per data row
  std::vector<std::uint32_t> slot_of;     // per data row: its index in its cluster's rows

  // Storage a decoder needs: per cluster mean, basis (fp32, or fp16 with half_basis),
  // coefficients in `format`,
  // Unorm8 offsets and scales; plus one cluster id and slot per row (u32 each).
  [[nodiscard]] std::size_t compressed_bytes() const;
  [[nodiscard]] std::size_t total_components() const;
};

// Compresses each cluster (labels: one per row, in [0, cluster_count)) with its own PCA.
// Empty clusters are kept with no rows. Errors: label out of range, size mismatch,
// non-finite data.
[[nodiscard]] Result<Cpca> compress(const Matrix& data, std::span<const std::uint32_t> labels,
                                    std::size_t cluster_count, const CpcaOptions& options = {});
// One row back, into `out` (cols values).
void reconstruct_row(const Cpca& cpca, std::size_t row, std::span<float> out);
[[nodiscard]] Matrix reconstruct(const Cpca& cpca);

// fp16 conversion shared with file formats (round to nearest even; overflow to infinity).
[[nodiscard]] std::uint16_t float_to_half(float value);
[[nodiscard]] float half_to_float(std::uint16_t bits);

}  // namespace weft::cluster
