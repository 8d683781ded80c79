// The trained model against the data: RMSE of decode() over every measured (light, view)
// pair of every texel, batched per texel through Eigen (decode() one sample at a time would
// take minutes at the paper's size).
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <vector>
#include <Eigen/Dense>
#include <weft/try.h>
module weft.btf.training;
import weft.cluster;

namespace weft::btf {

Result<double> model_rmse(const NeuralBtf& model, const Btf& btf, std::span<const bool> pairs, std::size_t threads) {
  WEFT_TRY_VOID(validate(model));
  if (model.width != btf.width || model.height != btf.height)
    return fail(ErrorKind::InvalidArgument, "model of {} x {} texels against a BTF of {} x {}", model.width, model.height,
                btf.width, btf.height);
  const std::size_t n_pairs = btf.samples_per_texel();
  if (!pairs.empty() && pairs.size() != n_pairs)
    return fail(ErrorKind::InvalidArgument, "pair mask of {} entries for {} light x view pairs", pairs.size(), n_pairs);
  std::vector<std::uint32_t> chosen;
  for (std::size_t i = 0; i < n_pairs; ++i)
    if (pairs.empty() || pairs[i]) chosen.push_back(std::uint32_t(i));
  if (chosen.empty() || btf.texels() == 0) return 0.0;
  const std::size_t L = model.latent_size, views = btf.views.size();
  // The direction part of the decoder's input is the same for every texel.
  Eigen::MatrixXf directions(4, Eigen::Index(chosen.size()));
  for (std::size_t j = 0; j < chosen.size(); ++j) {
    const vec2 li = stereographic(to_vector(btf.lights[chosen[j] / views]));
    const vec2 vo = stereographic(to_vector(btf.views[chosen[j] % views]));
    directions.col(Eigen::Index(j)) << li.x, li.y, vo.x, vo.y;
  }
  using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  std::vector<double> per_texel(btf.texels(), 0.0);
  cluster::parallel_for(btf.texels(), threads, [&](std::size_t begin, std::size_t end) {
    Eigen::MatrixXf a(Eigen::Index(L + 4), Eigen::Index(chosen.size()));
    for (std::size_t t = begin; t < end; ++t) {
      const auto latent = model.latent_of_texel(t);
      for (std::size_t k = 0; k < L; ++k) a.row(Eigen::Index(k)).setConstant(latent[k]);
      a.bottomRows(4) = directions;
      Eigen::MatrixXf x = a;
      for (std::size_t l = 0; l < model.decoder.layers.size(); ++l) {
        const DenseLayer& layer = model.decoder.layers[l];
        const Eigen::Map<const RowMatrix> w(layer.weights.data(), layer.outputs, layer.inputs);
        Eigen::MatrixXf z = w * x;
        z.colwise() += Eigen::Map<const Eigen::VectorXf>(layer.bias.data(), layer.outputs);
        x = (l + 1 < model.decoder.layers.size()) ? Eigen::MatrixXf(z.cwiseMax(0.0f)) : z;
      }
      const float scale = model.output_scale * (model.texel_scales.empty() ? 1.0f : model.texel_scales[t]);
      double sum = 0.0;
      for (std::size_t j = 0; j < chosen.size(); ++j) {
        const vec3 s = sample(btf, t, chosen[j] / views, chosen[j] % views);
        for (int c = 0; c < 3; ++c) {
          const double e = double(std::max(x(c, Eigen::Index(j)), 0.0f) * scale) - double(s[c]);
          sum += e * e;
        }
      }
      per_texel[t] = sum;
    }
  });
  double sum = 0.0;
  for (double s : per_texel) sum += s;  // serial: the same total for any thread count
  return std::sqrt(sum / double(btf.texels() * chosen.size() * 3));
}

}  // namespace weft::btf
