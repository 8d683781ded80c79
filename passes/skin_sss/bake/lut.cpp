// The pre-integrated skin LUT: the sum-of-Gaussians profile, the ring integral under either
// integration range, the Beckmann term of the KS specular, generation on every core, the
// CPU versions of the shader's lookups, files, and the content-hash cache.
module;
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.pass.skin_sss;

namespace weft::skin {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr ProfileGaussian kSkin[6] = {
    {0.0064, {0.233, 0.455, 0.649}}, {0.0484, {0.100, 0.336, 0.344}}, {0.187, {0.118, 0.198, 0.0}},
    {0.567, {0.113, 0.007, 0.007}},  {1.99, {0.358, 0.004, 0.0}},     {7.41, {0.078, 0.0, 0.0}},
};

double normalisation(double variance, Normalization n) {
  return n == Normalization::Planar ? 1.0 / (2.0 * kPi * variance) : 1.0 / std::sqrt(2.0 * kPi * variance);
}

// The ring quadrature of one radius: for each Gaussian, nodes (cos x, sin x, weight) with
// weight = exp(-chord²/2V) dx, and the Gaussian's channel weights times its normalisation.
struct RingGrid {
  struct Node {
    double cos_x, sin_x, weight;
  };
  struct Term {
    dvec3 channel_weight{0.0};
    std::vector<Node> nodes;
  };
  std::vector<Term> terms;
  dvec3 denominator{0.0};
  bool flat = false;  // 1/r = 0, or the quadrature caught nothing: max(cos θ, 0)
};

RingGrid make_grid(double radius_mm, const RingOptions& options, std::span<const ProfileGaussian> gaussians) {
  RingGrid grid;
  if (std::isnan(radius_mm) || std::isinf(radius_mm)) {
    grid.flat = true;
    return grid;
  }
  const double r = std::max(radius_mm, 0.0);
  const double half = half_range(options.range, r);
  const std::uint32_t n = std::max<std::uint32_t>(options.samples, 2);
  for (const ProfileGaussian& g : gaussians) {
    const double v = g.variance * options.convention.variance_scale;
    RingGrid::Term term;
    term.channel_weight = g.weight * normalisation(v, options.convention.normalization);
    if (!(v > 0.0) || !std::isfinite(v) || glm::dot(g.weight, dvec3(1.0)) == 0.0) continue;
    double extent = half;
    if (options.quadrature == Quadrature::PerGaussian) {
      const double sigma6 = 6.0 * std::sqrt(v);  // the chord beyond which exp(-d²/2v) < 2e-8
      if (sigma6 < 2.0 * r) extent = std::min(half, 2.0 * std::asin(sigma6 / (2.0 * r)));
    }
    const double dx = 2.0 * extent / n;
    term.nodes.reserve(n);
    double mass = 0.0;
    for (std::uint32_t k = 0; k < n; ++k) {
      const double x = -extent + (k + 0.5) * dx;
      const double chord = 2.0 * r * std::sin(0.5 * x);
      const double w = std::exp(-chord * chord / (2.0 * v)) * dx;
      if (w == 0.0) continue;
      term.nodes.push_back({std::cos(x), std::sin(x), w});
      mass += w;
    }
    grid.denominator += term.channel_weight * mass;
    grid.terms.push_back(std::move(term));
  }
  return grid;
}

dvec3 evaluate(const RingGrid& grid, double cos_theta) {
  const double c = std::clamp(cos_theta, -1.0, 1.0);
  const double flat = std::max(c, 0.0);
  if (grid.flat) return dvec3(flat);
  const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
  dvec3 numerator(0.0);
  for (const auto& term : grid.terms) {
    double sum = 0.0;
    for (const auto& node : term.nodes) sum += std::max(c * node.cos_x - s * node.sin_x, 0.0) * node.weight;
    numerator += term.channel_weight * sum;
  }
  dvec3 out;
  for (int ch = 0; ch < 3; ++ch) {
    const double den = grid.denominator[ch];
    out[ch] = den > 0.0 && std::isfinite(den) ? std::clamp(numerator[ch] / den, 0.0, 1.0) : flat;
  }
  return out;
}

// Runs body(row) for rows [0, count) on `threads` threads (0: all hardware threads).
template <class Body>
void parallel_rows(std::uint32_t count, std::uint32_t threads, Body body) {
  std::uint32_t n = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  n = std::min(n, count);
  if (n <= 1) {
    for (std::uint32_t row = 0; row < count; ++row) body(row);
    return;
  }
  std::atomic<std::uint32_t> next{0};
  std::vector<std::thread> pool;
  pool.reserve(n);
  for (std::uint32_t t = 0; t < n; ++t)
    pool.emplace_back([&] {
      for (std::uint32_t row = next++; row < count; row = next++) body(row);
    });
  for (auto& th : pool) th.join();
}

}  // namespace

std::span<const ProfileGaussian> skin_profile() { return kSkin; }

std::string_view to_string(Normalization n) { return n == Normalization::Planar ? "planar" : "ring"; }

dvec3 profile(double distance_mm, ProfileConvention convention, std::span<const ProfileGaussian> gaussians) {
  dvec3 sum(0.0);
  for (const ProfileGaussian& g : gaussians) {
    const double v = g.variance * convention.variance_scale;
    if (!(v > 0.0)) continue;
    sum += g.weight * normalisation(v, convention.normalization) * std::exp(-distance_mm * distance_mm / (2.0 * v));
  }
  return sum;
}

dvec3 transmittance(double thickness_mm, std::span<const ProfileGaussian> gaussians) {
  const double s = std::isfinite(thickness_mm) ? thickness_mm : kInf;
  dvec3 sum(0.0);
  for (const ProfileGaussian& g : gaussians)
    if (g.variance > 0.0) sum += g.weight * std::exp(-s * s / g.variance);
  return glm::clamp(sum, dvec3(0.0), dvec3(1.0));
}

constexpr EnumNames<IntegrationRange, 3> integration_range_names{
    {{IntegrationRange::Penner, "penner"}, {IntegrationRange::Adaptive, "adaptive"}, {IntegrationRange::Full, "full"}}};

std::string_view to_string(IntegrationRange range) { return enum_name(integration_range_names, range); }
Result<IntegrationRange> integration_range_from_string(std::string_view name) {
  return enum_from_name(integration_range_names, name, "integration range");
}

std::string_view to_string(Quadrature q) { return q == Quadrature::PerGaussian ? "per-gaussian" : "uniform"; }

double half_range(IntegrationRange range, double radius_mm) {
  switch (range) {
    case IntegrationRange::Penner: return 0.5 * kPi;
    case IntegrationRange::Full: return kPi;
    case IntegrationRange::Adaptive:
      if (std::isinf(radius_mm)) return 0.5 * kPi;
      if (!(radius_mm > 0.0)) return kPi;
      return std::min(kPi, kPi * (radius_mm + 1.0) / (2.0 * radius_mm));
  }
  return 0.5 * kPi;
}

dvec3 integrate_ring(double cos_theta, double radius_mm, const RingOptions& options) {
  return evaluate(make_grid(radius_mm, options, kSkin), cos_theta);
}

// ---- specular -------------------------------------------------------------------------

double beckmann(double n_dot_h, double m) {
  if (std::isnan(n_dot_h) || std::isnan(m)) return 0.0;
  if (n_dot_h <= 0.0) return 0.0;
  const double c = std::min(n_dot_h, 1.0);
  if (!(m > 0.0)) return c >= 1.0 ? kInf : 0.0;
  const double c2 = c * c, m2 = m * m;
  const double tan2 = (1.0 - c2) / c2;
  return std::exp(-tan2 / m2) / (m2 * c2 * c2);
}

double encode_beckmann(double p) {
  if (std::isnan(p) || p <= 0.0) return 0.0;
  if (std::isinf(p)) return 1.0;
  return std::min(0.5 * std::pow(p, 0.1), 1.0);
}

double decode_beckmann(double encoded) { return std::pow(2.0 * std::clamp(encoded, 0.0, 1.0), 10.0); }

double fresnel_schlick(double v_dot_h, double f0) {
  const double base = 1.0 - std::clamp(v_dot_h, 0.0, 1.0);
  const double e = base * base * base * base * base;
  return e + f0 * (1.0 - e);
}

double ks_specular(const dvec3& n, const dvec3& l, const dvec3& v, double m, double rho_s, double f0) {
  const double n_dot_l = glm::dot(n, l);
  if (!(n_dot_l > 0.0)) return 0.0;
  const dvec3 h = l + v;
  const double hh = glm::dot(h, h);
  if (!(hh > 0.0)) return 0.0;
  const dvec3 hn = h / std::sqrt(hh);
  const double p = beckmann(glm::dot(n, hn), m);
  const double f = fresnel_schlick(glm::dot(v, hn), f0);
  const double spec = std::max(p * f / hh, 0.0);
  return std::isfinite(spec) ? n_dot_l * rho_s * spec : 0.0;
}

// ---- the LUT --------------------------------------------------------------------------

std::uint64_t LutParams::hash() const {
  Hasher h;
  h.str("weft.skin-lut.v1");
  h.value(width).value(height).value(std::uint8_t(range)).value(std::uint8_t(convention.normalization));
  h.value(convention.variance_scale).value(max_curvature).value(samples).value(std::uint8_t(quadrature));
  return h.digest();
}

std::string LutParams::describe() const {
  return weft::format("{}x{} {} {}/{:g} max {:g}/mm {} samples {}", width, height, to_string(range),
                      to_string(convention.normalization), convention.variance_scale, max_curvature, samples,
                      to_string(quadrature));
}

Result<void> validate(const LutParams& p) {
  if (p.width < 2 || p.width > 4096) return fail(ErrorKind::InvalidArgument, "skin LUT width {} is outside 2..4096", p.width);
  if (p.height < 2 || p.height > 4096)
    return fail(ErrorKind::InvalidArgument, "skin LUT height {} is outside 2..4096", p.height);
  if (!(p.max_curvature > 0.0) || p.max_curvature > 10.0)
    return fail(ErrorKind::InvalidArgument, "skin LUT max_curvature {} is outside (0, 10] (1/mm)", p.max_curvature);
  if (p.samples < 2 || p.samples > 65536)
    return fail(ErrorKind::InvalidArgument, "skin LUT samples {} is outside 2..65536", p.samples);
  if (!(p.convention.variance_scale > 0.0) || !std::isfinite(p.convention.variance_scale))
    return fail(ErrorKind::InvalidArgument, "skin LUT variance scale {} must be positive and finite",
                p.convention.variance_scale);
  // The cost is texels x samples (256x256 at 256 samples: about 0.12 s on one core); each
  // knob alone may reach its end, but not all at once (4096x4096 at 65,536 samples would
  // take about two hours).
  constexpr std::uint64_t max_work = std::uint64_t{1} << 32;
  const std::uint64_t work = std::uint64_t(p.width) * p.height * p.samples;
  if (work > max_work)
    return fail(ErrorKind::InvalidArgument,
                "skin LUT {}x{} with {} samples is {:.3g} texel-samples, more than the limit of {:.3g} (about 30 s on one "
                "core): use fewer texels or samples",
                p.width, p.height, p.samples, double(work), double(max_work));
  return {};
}

double SkinLut::n_dot_l_at(std::uint32_t x) const { return -1.0 + 2.0 * double(x) / double(width - 1); }
double SkinLut::curvature_at(std::uint32_t y) const { return params.max_curvature * double(y) / double(height - 1); }

Result<SkinLut> generate_lut(const LutParams& params) {
  WEFT_TRY_VOID(validate(params));
  SkinLut lut;
  lut.params = params;
  lut.width = params.width;
  lut.height = params.height;
  lut.hash = params.hash();
  lut.texels.resize(std::size_t(lut.width) * lut.height);
  const RingOptions ring = params.ring();
  parallel_rows(lut.height, params.threads, [&](std::uint32_t y) {
    const double curvature = lut.curvature_at(y);
    const RingGrid grid = make_grid(curvature > 0.0 ? 1.0 / curvature : kInf, ring, kSkin);
    const double m = double(y) / double(lut.height - 1);
    vec4* row = &lut.texels[std::size_t(y) * lut.width];
    for (std::uint32_t x = 0; x < lut.width; ++x) {
      const dvec3 d = evaluate(grid, lut.n_dot_l_at(x));
      const double n_dot_h = double(x) / double(lut.width - 1);
      row[x] = vec4(vec3(d), float(encode_beckmann(beckmann(n_dot_h, m))));
    }
  });
  return lut;
}

float lut_coordinate(float x, std::uint32_t texels) {
  const float c = std::isnan(x) ? 0.0f : std::clamp(x, 0.0f, 1.0f);
  return (c * float(texels - 1) + 0.5f) / float(texels);
}

namespace {
vec4 bilinear(const SkinLut& lut, float fx, float fy) {
  const auto axis = [](float f, std::uint32_t n, std::uint32_t& i0, std::uint32_t& i1, float& t) {
    const float c = std::isnan(f) ? 0.0f : std::clamp(f, 0.0f, 1.0f);
    const float p = c * float(n - 1);
    i0 = std::min(std::uint32_t(p), n - 1);
    i1 = std::min(i0 + 1, n - 1);
    t = p - float(i0);
  };
  std::uint32_t x0, x1, y0, y1;
  float tx, ty;
  axis(fx, lut.width, x0, x1, tx);
  axis(fy, lut.height, y0, y1, ty);
  const vec4 a = glm::mix(lut.texel(x0, y0), lut.texel(x1, y0), tx);
  const vec4 b = glm::mix(lut.texel(x0, y1), lut.texel(x1, y1), tx);
  return glm::mix(a, b, ty);
}
}  // namespace

vec3 sample_diffuse(const SkinLut& lut, float n_dot_l, float curvature_per_mm) {
  return vec3(bilinear(lut, 0.5f * n_dot_l + 0.5f, curvature_per_mm / float(lut.params.max_curvature)));
}

float sample_specular(const SkinLut& lut, float n_dot_h, float m) {
  return float(decode_beckmann(bilinear(lut, n_dot_h, m).a));
}

image::Image to_image(const SkinLut& lut) {
  image::Image img = image::Image::filled(lut.width, lut.height, 4);
  for (std::size_t i = 0; i < lut.texels.size(); ++i)
    for (int c = 0; c < 4; ++c) img.pixels[i * 4 + c] = lut.texels[i][c];
  return img;
}

Result<void> save_lut(const std::filesystem::path& path, const SkinLut& lut, bool with_alpha) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  image::Image img = to_image(lut);
  if (ext == ".exr") return image::save_exr(path, img);
  if (ext == ".png") {
    if (!with_alpha) {
      image::Image rgb = image::Image::filled(lut.width, lut.height, 3);
      for (std::size_t i = 0; i < lut.texels.size(); ++i)
        for (int c = 0; c < 3; ++c) rgb.pixels[i * 3 + c] = lut.texels[i][c];
      img = std::move(rgb);
    }
    return image::save_png(path, image::to_srgb8(img));
  }
  return fail(ErrorKind::Unsupported, "skin LUT '{}': write .exr (the data) or .png (a picture)", path.string());
}

// ---- cache ----------------------------------------------------------------------------

namespace {
struct LutCache {
  std::mutex mutex;
  std::map<std::uint64_t, std::shared_ptr<const SkinLut>> memory;
  LutCacheStats stats;
};
LutCache& lut_cache() {
  static LutCache cache;
  return cache;
}
}  // namespace

std::filesystem::path lut_disk_cache_dir() {
  if (const char* dir = std::getenv("WEFT_SKIN_LUT_CACHE")) return *dir ? std::filesystem::path(dir) : std::filesystem::path();
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::filesystem::path(xdg) / "weft" / "skin-lut";
  if (const char* home = std::getenv("HOME"); home && *home) return std::filesystem::path(home) / ".cache" / "weft" / "skin-lut";
  return {};
}

Result<std::shared_ptr<const SkinLut>> cached_lut(const LutParams& params) {
  WEFT_TRY_VOID(validate(params));
  const std::uint64_t key = params.hash();
  auto& cache = lut_cache();
  {
    std::lock_guard lock(cache.mutex);
    if (auto it = cache.memory.find(key); it != cache.memory.end()) {
      ++cache.stats.memory_hits;
      return it->second;
    }
  }
  const std::filesystem::path dir = lut_disk_cache_dir();
  const std::filesystem::path file = dir.empty() ? std::filesystem::path() : dir / ("skin-lut-" + hex64(key) + ".exr");
  std::shared_ptr<const SkinLut> result;
  bool from_disk = false;
  if (!file.empty() && std::filesystem::exists(file)) {
    if (auto img = image::load_exr(file); img && img->width == params.width && img->height == params.height &&
                                          img->channels == 4) {
      auto lut = std::make_shared<SkinLut>();
      lut->params = params;
      lut->width = img->width;
      lut->height = img->height;
      lut->hash = key;
      lut->texels.resize(std::size_t(img->width) * img->height);
      bool finite = true;
      for (std::size_t i = 0; i < lut->texels.size(); ++i) {
        lut->texels[i] = vec4(img->pixels[i * 4], img->pixels[i * 4 + 1], img->pixels[i * 4 + 2], img->pixels[i * 4 + 3]);
        finite = finite && std::isfinite(lut->texels[i].x + lut->texels[i].y + lut->texels[i].z + lut->texels[i].w);
      }
      if (finite) {
        result = std::move(lut);
        from_disk = true;
      }
    }
    if (!from_disk) log::warn(weft::format("skin LUT cache file '{}' is unreadable; regenerating it", file.string()));
  }
  if (!result) {
    WEFT_TRY(auto lut, generate_lut(params));
    result = std::make_shared<const SkinLut>(std::move(lut));
    if (!file.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
      if (auto ok = image::save_exr(file, to_image(*result)); !ok)
        log::warn(weft::format("skin LUT cache: {}", ok.error().what()));
    }
  }
  std::lock_guard lock(cache.mutex);
  if (from_disk) ++cache.stats.disk_hits;
  else ++cache.stats.generated;
  return cache.memory.emplace(key, std::move(result)).first->second;
}

LutCacheStats lut_cache_stats() {
  std::lock_guard lock(lut_cache().mutex);
  return lut_cache().stats;
}

void clear_lut_memory_cache() {
  std::lock_guard lock(lut_cache().mutex);
  lut_cache().memory.clear();
}

}  // namespace weft::skin
