// PCA through the eigen decomposition of the smaller Gram matrix (rows x rows when rows <
// cols, else cols x cols), in double: exact rank, energies, both stopping rules.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <span>
#include <vector>
#include <Eigen/Dense>
module weft.cluster;
import weft.core;

namespace weft::cluster {
namespace {
// Eigenvalues below this fraction of the largest are noise of float input (a relative
// singular value of 1e-5 sits well above float rounding, far below any real component).
constexpr double kRankTolerance = 1e-10;

using MatrixD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using MatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
}  // namespace

double Pca::energy_fraction(std::size_t m) const {
  if (total_energy <= 0.0) return 1.0;
  double kept = 0.0;
  for (std::size_t i = 0; i < std::min(m, energy.size()); ++i) kept += energy[i];
  return std::min(1.0, kept / total_energy);
}

std::size_t components_for_energy(const Pca& pca, double fraction) {
  if (fraction >= 1.0) return pca.rank;
  if (pca.total_energy <= 0.0 || fraction <= 0.0) return 0;
  double kept = 0.0;
  for (std::size_t i = 0; i < pca.energy.size(); ++i) {
    kept += pca.energy[i];
    if (kept >= fraction * pca.total_energy) return i + 1;
  }
  return pca.rank;
}

Result<Pca> fit_pca(const Matrix& data, const PcaOptions& options) {
  if (data.rows == 0 || data.cols == 0)
    return fail(ErrorKind::InvalidArgument, "PCA of an empty matrix ({} x {})", data.rows, data.cols);
  if (data.values.size() != data.rows * data.cols)
    return fail(ErrorKind::InvalidArgument, "PCA: matrix holds {} values, not {} x {}", data.values.size(), data.rows,
                data.cols);
  if (!(options.energy_fraction >= 0.0 && options.energy_fraction <= 1.0))
    return fail(ErrorKind::InvalidArgument, "PCA: energy fraction {} is outside [0, 1]", options.energy_fraction);
  for (std::size_t i = 0; i < data.values.size(); ++i)
    if (!std::isfinite(data.values[i]))
      return fail(ErrorKind::InvalidArgument, "PCA: non-finite value at row {}, column {}", i / data.cols, i % data.cols);

  const auto n = static_cast<Eigen::Index>(data.rows), d = static_cast<Eigen::Index>(data.cols);
  MatrixD x = Eigen::Map<const MatrixF>(data.values.data(), n, d).cast<double>();
  Pca pca;
  Eigen::RowVectorXd mean = Eigen::RowVectorXd::Zero(d);
  if (options.center) {
    mean = x.colwise().mean();
    x.rowwise() -= mean;
  }
  pca.mean.resize(data.cols);
  for (Eigen::Index c = 0; c < d; ++c) pca.mean[static_cast<std::size_t>(c)] = static_cast<float>(mean[c]);
  pca.total_energy = x.squaredNorm();

  // Eigenpairs of the smaller Gram matrix, largest first; basis rows from either side.
  const bool by_rows = n < d;
  // Only the lower triangle: a symmetric rank update does half the work of a product, and
  // the solver reads nothing else.
  MatrixD gram = MatrixD::Zero(by_rows ? n : d, by_rows ? n : d);
  if (by_rows)
    gram.selfadjointView<Eigen::Lower>().rankUpdate(x);
  else
    gram.selfadjointView<Eigen::Lower>().rankUpdate(x.transpose());
  Eigen::SelfAdjointEigenSolver<MatrixD> solver(gram);
  const Eigen::VectorXd values = solver.eigenvalues();  // increasing
  const MatrixD& vectors = solver.eigenvectors();
  const double largest = values.size() ? std::max(0.0, values[values.size() - 1]) : 0.0;
  std::vector<Eigen::Index> order;
  for (Eigen::Index i = values.size() - 1; i >= 0; --i)
    if (largest > 0.0 && values[i] > kRankTolerance * largest) order.push_back(i);
  pca.rank = order.size();
  for (auto i : order) pca.energy.push_back(values[i]);

  std::size_t keep = std::min(options.max_components, components_for_energy(pca, options.energy_fraction));
  keep = std::min(keep, pca.rank);
  pca.basis = Matrix(keep, data.cols);
  for (std::size_t k = 0; k < keep; ++k) {
    Eigen::RowVectorXd v;
    if (by_rows) {
      // v = x^T u / sigma: the right singular vector for the left one u.
      v = (x.transpose() * vectors.col(order[k])).transpose() / std::sqrt(values[order[k]]);
    } else {
      v = vectors.col(order[k]).transpose();
    }
    v.normalize();
    for (Eigen::Index c = 0; c < d; ++c) pca.basis.at(k, static_cast<std::size_t>(c)) = static_cast<float>(v[c]);
  }
  return pca;
}

Matrix project(const Pca& pca, const Matrix& data) {
  const auto n = static_cast<Eigen::Index>(data.rows), d = static_cast<Eigen::Index>(data.cols);
  const auto m = static_cast<Eigen::Index>(pca.components());
  MatrixD x = Eigen::Map<const MatrixF>(data.values.data(), n, d).cast<double>();
  x.rowwise() -= Eigen::Map<const Eigen::RowVectorXf>(pca.mean.data(), d).cast<double>();
  const MatrixD basis = Eigen::Map<const MatrixF>(pca.basis.values.data(), m, d).cast<double>();
  Matrix out(data.rows, pca.components());
  Eigen::Map<MatrixF>(out.values.data(), n, m) = (x * basis.transpose()).cast<float>();
  return out;
}

Matrix reconstruct(const Pca& pca, const Matrix& coefficients) {
  const auto n = static_cast<Eigen::Index>(coefficients.rows), d = static_cast<Eigen::Index>(pca.mean.size());
  const auto m = static_cast<Eigen::Index>(std::min(coefficients.cols, pca.components()));
  const MatrixD a = Eigen::Map<const MatrixF, 0, Eigen::OuterStride<>>(coefficients.values.data(), n, m,
                                                                       Eigen::OuterStride<>(coefficients.cols))
                        .cast<double>();
  const MatrixD basis = Eigen::Map<const MatrixF>(pca.basis.values.data(), m, d).cast<double>();
  MatrixD x = a * basis;
  x.rowwise() += Eigen::Map<const Eigen::RowVectorXf>(pca.mean.data(), d).cast<double>();
  Matrix out(coefficients.rows, pca.mean.size());
  Eigen::Map<MatrixF>(out.values.data(), n, d) = x.cast<float>();
  return out;
}

}  // namespace weft::cluster
