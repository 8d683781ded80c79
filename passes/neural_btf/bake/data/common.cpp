// Checks and small helpers on a Btf: validation with errors that locate the bad sample,
// crops, direction subsets, per-texel luminance, RMSE and texel images.
module;
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
module weft.btf;
import weft.cluster;

namespace weft::btf {
namespace {
bool same_directions(std::span<const Direction> a, std::span<const Direction> b) {
  return std::ranges::equal(a, b, [](Direction x, Direction y) { return x.theta == y.theta && x.phi == y.phi; });
}
}  // namespace

Result<void> validate(const Btf& btf, std::string_view source) {
  if (btf.width == 0 || btf.height == 0)
    return fail(ErrorKind::InvalidArgument, "{}: BTF of {} x {} texels (both must be at least 1)", source, btf.width,
                btf.height);
  if (btf.lights.empty() || btf.views.empty())
    return fail(ErrorKind::InvalidArgument, "{}: BTF with {} lights and {} views (both must be at least 1)", source,
                btf.lights.size(), btf.views.size());
  const std::size_t expected = btf.texels() * btf.abrdf_floats();
  if (btf.rgb.size() != expected)
    return fail(ErrorKind::InvalidArgument, "{}: BTF holds {} floats, not {} ({} x {} texels x {} lights x {} views x 3)",
                source, btf.rgb.size(), expected, btf.width, btf.height, btf.lights.size(), btf.views.size());
  for (const auto* set : {&btf.lights, &btf.views})
    for (std::size_t i = 0; i < set->size(); ++i) {
      const Direction d = (*set)[i];
      if (!std::isfinite(d.theta) || !std::isfinite(d.phi) || d.theta < 0.0f || d.theta > 0.5f * pi + 1e-6f)
        return fail(ErrorKind::InvalidArgument, "{}: {} {} ({}) is not a direction of the upper hemisphere", source,
                    set == &btf.lights ? "light" : "view", i, describe(d));
    }
  for (std::size_t i = 0; i < btf.rgb.size(); ++i) {
    const float value = btf.rgb[i];
    if (std::isfinite(value) && value >= 0.0f) continue;
    const std::size_t c = i % 3, pair = i / 3 % btf.samples_per_texel(), texel = i / btf.abrdf_floats();
    const std::size_t l = pair / btf.views.size(), v = pair % btf.views.size();
    return fail(ErrorKind::InvalidArgument,
                "{}: sample {} (not finite and >= 0) at texel ({}, {}), light {} ({}), view {} ({}), channel {}", source,
                value, texel % btf.width, texel / btf.width, l, describe(btf.lights[l]), v, describe(btf.views[v]),
                "rgb"[c]);
  }
  return {};
}

vec3 sample(const Btf& btf, std::size_t texel, std::size_t l, std::size_t v) {
  const float* p = btf.rgb.data() + ((texel * btf.lights.size() + l) * btf.views.size() + v) * 3;
  return {p[0], p[1], p[2]};
}

Result<Btf> crop(const Btf& btf, const Crop& c) {
  const std::uint32_t w = c.width ? c.width : (c.x < btf.width ? btf.width - c.x : 0);
  const std::uint32_t h = c.height ? c.height : (c.y < btf.height ? btf.height - c.y : 0);
  if (w == 0 || h == 0 || std::uint64_t(c.x) + w > btf.width || std::uint64_t(c.y) + h > btf.height)
    return fail(ErrorKind::InvalidArgument, "crop ({}, {}) size {} x {} does not fit a {} x {} BTF", c.x, c.y, c.width,
                c.height, btf.width, btf.height);
  Btf out{w, h, btf.lights, btf.views, {}};
  const std::size_t n = btf.abrdf_floats();
  out.rgb.resize(out.texels() * n);
  for (std::uint32_t y = 0; y < h; ++y)
    std::copy_n(btf.rgb.data() + (std::size_t(c.y + y) * btf.width + c.x) * n, std::size_t(w) * n,
                out.rgb.data() + std::size_t(y) * w * n);
  return out;
}

Result<Btf> select_directions(const Btf& btf, std::span<const std::size_t> lights, std::span<const std::size_t> views) {
  for (auto l : lights)
    if (l >= btf.lights.size())
      return fail(ErrorKind::InvalidArgument, "light index {} out of range (the BTF has {} lights)", l, btf.lights.size());
  for (auto v : views)
    if (v >= btf.views.size())
      return fail(ErrorKind::InvalidArgument, "view index {} out of range (the BTF has {} views)", v, btf.views.size());
  Btf out{btf.width, btf.height, {}, {}, {}};
  for (auto l : lights) out.lights.push_back(btf.lights[l]);
  for (auto v : views) out.views.push_back(btf.views[v]);
  out.rgb.resize(out.texels() * out.abrdf_floats());
  float* dst = out.rgb.data();
  for (std::size_t t = 0; t < btf.texels(); ++t)
    for (auto l : lights)
      for (auto v : views) {
        const vec3 s = sample(btf, t, l, v);
        *dst++ = s.r, *dst++ = s.g, *dst++ = s.b;
      }
  return out;
}

float abrdf_luminance(std::span<const float> abrdf) {
  const std::size_t n = abrdf.size() / 3;
  double sum = 0.0;
  for (std::size_t s = 0; s < n; ++s) sum += 0.2126 * abrdf[s * 3] + 0.7152 * abrdf[s * 3 + 1] + 0.0722 * abrdf[s * 3 + 2];
  return n ? static_cast<float>(sum / double(n)) : 0.0f;
}

std::vector<float> mean_luminance(const Btf& btf) {
  std::vector<float> out(btf.texels(), 0.0f);
  for (std::size_t t = 0; t < btf.texels(); ++t) out[t] = abrdf_luminance(btf.abrdf(t));
  return out;
}

double constant_rmse(const Btf& btf) {
  const std::size_t samples = btf.rgb.size() / 3;
  if (samples == 0) return 0.0;
  double mean[3] = {0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < btf.rgb.size(); ++i) mean[i % 3] += btf.rgb[i];
  for (double& m : mean) m /= double(samples);
  double sq = 0.0;
  for (std::size_t i = 0; i < btf.rgb.size(); ++i) {
    const double d = btf.rgb[i] - mean[i % 3];
    sq += d * d;
  }
  return std::sqrt(sq / double(btf.rgb.size()));
}

Result<double> rmse(const Btf& a, const Btf& b) {
  if (a.width != b.width || a.height != b.height || !same_directions(a.lights, b.lights) ||
      !same_directions(a.views, b.views) || a.rgb.size() != b.rgb.size())
    return fail(ErrorKind::InvalidArgument,
                "RMSE of BTFs that differ in size or directions ({} x {} texels, {} x {} directions vs {} x {}, {} x {})",
                a.width, a.height, a.lights.size(), a.views.size(), b.width, b.height, b.lights.size(), b.views.size());
  if (a.rgb.empty()) return 0.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) {
    const double d = double(a.rgb[i]) - double(b.rgb[i]);
    sum += d * d;
  }
  return std::sqrt(sum / double(a.rgb.size()));
}

double rmse(const Btf& reference, const ReflectanceFn& model, std::size_t threads) {
  if (reference.rgb.empty()) return 0.0;
  std::vector<vec3> lights, views;
  for (auto d : reference.lights) lights.push_back(to_vector(d));
  for (auto d : reference.views) views.push_back(to_vector(d));
  std::vector<double> per_texel(reference.texels(), 0.0);
  cluster::parallel_for(reference.texels(), threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t < end; ++t) {
      double sum = 0.0;
      for (std::size_t l = 0; l < lights.size(); ++l)
        for (std::size_t v = 0; v < views.size(); ++v) {
          const vec3 d = model(t, lights[l], views[v]) - sample(reference, t, l, v);
          sum += double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
        }
      per_texel[t] = sum;
    }
  });
  double sum = 0.0;
  for (double s : per_texel) sum += s;  // serial: the same total whatever the thread count
  return std::sqrt(sum / double(reference.rgb.size()));
}

image::Image texel_image(const Btf& btf, std::size_t l, std::size_t v) {
  auto img = image::Image::filled(btf.width, btf.height, 3);
  for (std::size_t t = 0; t < btf.texels(); ++t) {
    const vec3 s = sample(btf, t, l, v);
    img.pixels[t * 3] = s.r, img.pixels[t * 3 + 1] = s.g, img.pixels[t * 3 + 2] = s.b;
  }
  return img;
}

}  // namespace weft::btf
