// Reference sampling: the raw BTF between measured directions. Per direction set, the 3
// nearest measured directions weighted by 1/d² − 1/d₄² (Shepard weights cut off at the 4th
// nearest distance): a direction's weight falls to 0 exactly as it leaves the nearest three,
// so the interpolant is continuous, and it is exact at a measured direction (d = 0).
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <vector>
#include <glm/glm.hpp>
module weft.btf;

namespace weft::btf {

DirectionWeights interpolation_weights(std::span<const Direction> measured, const vec3& direction) {
  DirectionWeights w;
  if (measured.empty()) return w;
  const float len = glm::length(direction);
  const vec3 q = len > 0.0f ? direction / len : vec3(0, 0, 1);
  // The 4 nearest by squared chord distance (ties: lower index), kept sorted.
  constexpr float inf = std::numeric_limits<float>::infinity();
  std::array<float, 4> d2{inf, inf, inf, inf};
  std::array<std::size_t, 4> idx{0, 0, 0, 0};
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const vec3 m = to_vector(measured[i]);
    const vec3 diff = m - q;
    const float d = glm::dot(diff, diff);
    if (d >= d2[3]) continue;
    std::size_t k = 3;
    while (k > 0 && d < d2[k - 1]) {
      d2[k] = d2[k - 1], idx[k] = idx[k - 1];
      --k;
    }
    d2[k] = d, idx[k] = i;
  }
  w.count = std::min<std::size_t>(3, measured.size());
  for (std::size_t k = 0; k < w.count; ++k) w.index[k] = idx[k];
  if (d2[0] <= 1e-12f) {  // a measured direction: exactly its sample
    w.weight[0] = 1.0f;
    return w;
  }
  const double cutoff = measured.size() > 3 ? 1.0 / double(d2[3]) : 0.0;
  double raw[3] = {0, 0, 0}, sum = 0.0;
  for (std::size_t k = 0; k < w.count; ++k) sum += raw[k] = std::max(0.0, 1.0 / double(d2[k]) - cutoff);
  if (sum <= 0.0) {  // all four equally far (a point of symmetry): equal weights
    for (std::size_t k = 0; k < w.count; ++k) raw[k] = 1.0;
    sum = double(w.count);
  }
  for (std::size_t k = 0; k < w.count; ++k) w.weight[k] = static_cast<float>(raw[k] / sum);
  return w;
}

vec3 sample_reference(const Btf& btf, std::size_t texel, const vec3& light, const vec3& view) {
  const DirectionWeights wl = interpolation_weights(btf.lights, light);
  const DirectionWeights wv = interpolation_weights(btf.views, view);
  vec3 out(0.0f);
  for (std::size_t a = 0; a < wl.count; ++a) {
    if (wl.weight[a] == 0.0f) continue;
    for (std::size_t b = 0; b < wv.count; ++b)
      if (wv.weight[b] != 0.0f) out += wl.weight[a] * wv.weight[b] * sample(btf, texel, wl.index[a], wv.index[b]);
  }
  return out;
}

}  // namespace weft::btf
