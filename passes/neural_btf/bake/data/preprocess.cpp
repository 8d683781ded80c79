// The paper's preprocessing: inputs standardize(log(x + 1)) per ABRDF dimension over the
// texels, targets rgb / global max. Sums run in double (10,000 texels of values up to
// float's max stay finite); a dimension with no spread gets std 1, so a constant ABRDF maps
// to 0 instead of 0 / 0.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>
module weft.btf;
import weft.cluster;

namespace weft::btf {
namespace {
// Below this the spread is float rounding of a constant, not signal.
constexpr double kMinStd = 1e-6;
}  // namespace

Preprocessing preprocessing_constants(const Btf& btf) {
  const std::size_t n = btf.abrdf_floats(), texels = btf.texels();
  Preprocessing p;
  p.mean.assign(n, 0.0f);
  p.std.assign(n, 1.0f);
  if (texels == 0 || btf.rgb.size() != texels * n) return p;
  // Per dimension over texels; dimensions split across threads (each writes its own range).
  cluster::parallel_for(n, 0, [&](std::size_t begin, std::size_t end) {
    std::vector<double> sum(end - begin, 0.0), sum2(end - begin, 0.0);
    for (std::size_t t = 0; t < texels; ++t) {
      const float* row = btf.rgb.data() + t * n;
      for (std::size_t d = begin; d < end; ++d) {
        const double x = std::log1p(std::max(0.0, double(row[d])));
        sum[d - begin] += x;
        sum2[d - begin] += x * x;
      }
    }
    for (std::size_t d = begin; d < end; ++d) {
      const double mean = sum[d - begin] / double(texels);
      const double var = std::max(0.0, sum2[d - begin] / double(texels) - mean * mean);
      const double sd = std::sqrt(var);
      p.mean[d] = static_cast<float>(mean);
      p.std[d] = sd > kMinStd * std::max(1.0, std::abs(mean)) ? static_cast<float>(sd) : 1.0f;
    }
  });
  float max = 0.0f;
  for (float v : btf.rgb) max = std::max(max, v);
  p.target_max = max > 0.0f && std::isfinite(max) ? max : 1.0f;
  return p;
}

void preprocess_input(const Preprocessing& c, std::span<const float> abrdf, std::span<float> out) {
  const std::size_t n = std::min({abrdf.size(), out.size(), c.mean.size(), c.std.size()});
  for (std::size_t d = 0; d < n; ++d)
    out[d] = static_cast<float>((std::log1p(std::max(0.0, double(abrdf[d]))) - double(c.mean[d])) / double(c.std[d]));
}

Preprocessed preprocess(const Btf& btf) {
  Preprocessed out;
  out.constants = preprocessing_constants(btf);
  const std::size_t n = btf.abrdf_floats(), texels = btf.texels();
  if (btf.rgb.size() != texels * n) return out;
  out.inputs.resize(btf.rgb.size());
  out.targets.resize(btf.rgb.size());
  const float max = out.constants.target_max;
  cluster::parallel_for(texels, 0, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t < end; ++t) {
      preprocess_input(out.constants, btf.abrdf(t), std::span(out.inputs).subspan(t * n, n));
      for (std::size_t d = 0; d < n; ++d) out.targets[t * n + d] = btf.rgb[t * n + d] / max;  // exactly 1 at the max
    }
  });
  return out;
}

}  // namespace weft::btf
