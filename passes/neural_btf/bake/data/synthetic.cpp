// The synthetic fabric BTF: a procedural height field and albedo (woven or knitted yarns),
// sampled on a grid of subsamples x subsamples points per texel (plus a margin the shadow
// rays can reach), shaded per (light, view) with GGX + Lambert, soft self-shadowing and
// masking by ray-marching the grid. Every texel is independent, so threads split texels and
// the result does not depend on their number.
module;
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <unistd.h>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.btf;
import weft.cluster;

namespace weft::btf {
namespace {

// ---- deterministic noise ----------------------------------------------------------------

std::uint64_t mix64(std::uint64_t z) {  // splitmix64's finaliser
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
// A uniform float in [0, 1) from a seed, two lattice coordinates and a salt.
float hash01(std::uint64_t seed, std::int64_t a, std::int64_t b, std::uint64_t salt) {
  std::uint64_t h = mix64(seed ^ 0x9e3779b97f4a7c15ull);
  h = mix64(h ^ static_cast<std::uint64_t>(a) ^ (salt << 56));
  h = mix64(h ^ static_cast<std::uint64_t>(b) * 0x632be59bd9b4e019ull);
  return float(h >> 40) * 0x1.0p-24f;
}
// Smooth value noise in [0, 1] with unit lattice spacing.
float value_noise(std::uint64_t seed, float x, float y, std::uint64_t salt) {
  const float fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const float tx = x - fx, ty = y - fy;
  const float sx = tx * tx * (3.0f - 2.0f * tx), sy = ty * ty * (3.0f - 2.0f * ty);
  const float a = hash01(seed, ix, iy, salt), b = hash01(seed, ix + 1, iy, salt);
  const float c = hash01(seed, ix, iy + 1, salt), d = hash01(seed, ix + 1, iy + 1, salt);
  return (a + (b - a) * sx) + ((c + (d - c) * sx) - (a + (b - a) * sx)) * sy;
}
float smooth01(float t) { return 0.5f - 0.5f * std::cos(pi * std::clamp(t, 0.0f, 1.0f)); }
std::int64_t floor_int(float v) { return static_cast<std::int64_t>(std::floor(v)); }

// ---- the fabric -------------------------------------------------------------------------

struct SurfacePoint {
  float height = 0.0f;
  vec3 albedo{0.0f};
};

class Fabric {
 public:
  explicit Fabric(const SyntheticOptions& o) : o_(o) {
    s_ = o.yarn_spacing;
    crown_ = 0.5f * o.relief * s_;
    lift_ = 0.25f * o.relief * s_;
    floor_ = -lift_ - 0.3f * crown_;
  }
  [[nodiscard]] float lowest() const { return floor_; }
  [[nodiscard]] float highest() const { return lift_ + crown_ * (1.0f + o_.fibre_detail); }

  [[nodiscard]] SurfacePoint at(float x, float y) const {
    return o_.weave == Weave::Knit ? knit(x, y) : woven(x, y);
  }

 private:
  // Whether warp yarn i lies over weft yarn j.
  [[nodiscard]] bool warp_over(std::int64_t i, std::int64_t j) const {
    if (o_.weave == Weave::Plain) return ((i + j) & 1) == 0;
    return (((i - j) % 4) + 4) % 4 != 0;  // 3/1 twill: a diagonal of weft floats every 4th pick
  }
  // A yarn's colour: the base with per-yarn jitter and streaks along the fibres.
  [[nodiscard]] vec3 yarn_color(vec3 base, std::int64_t yarn, std::uint64_t salt, float along, float across) const {
    const float j = o_.color_jitter * (2.0f * hash01(o_.seed, yarn, 0, salt) - 1.0f);
    vec3 c = base * (1.0f + j);
    for (int k = 0; k < 3; ++k)
      c[k] *= 1.0f + 0.3f * o_.color_jitter * (2.0f * hash01(o_.seed, yarn, k + 1, salt) - 1.0f);
    const float streak = value_noise(o_.seed, along / (0.6f * s_), across / 0.7f + float(yarn) * 17.0f, salt + 1);
    const float fine = value_noise(o_.seed, along / 1.3f, across / 0.35f + float(yarn) * 31.0f, salt + 2);
    return c * std::max(0.0f, 1.0f + o_.albedo_noise * (1.4f * streak + 0.6f * fine - 1.0f) * 2.0f);
  }
  // Twist ridges across a yarn: plies wound at about 40°.
  [[nodiscard]] float ridges(float along, float across_fraction) const {
    const float phase = 2.0f * pi * (along / (0.3f * s_) + across_fraction * 1.6f);
    return o_.fibre_detail * crown_ * 0.5f * (1.0f + std::sin(phase));
  }

  [[nodiscard]] SurfacePoint woven(float x, float y) const {
    const float gx = x / s_, gy = y / s_;
    const std::int64_t i = floor_int(gx), j = floor_int(gy);  // warp yarn (column), weft yarn (row)
    const float u = gx - float(i) - 0.5f, v = gy - float(j) - 0.5f;
    const float half = 0.5f * o_.yarn_width;
    // Undulation: +1 over a crossing, -1 under it, eased between crossing centres.
    auto lift_along = [&](float g, std::int64_t other, bool warp) {
      const float t = g - 0.5f;
      const std::int64_t k0 = floor_int(t);
      auto c = [&](std::int64_t k) {
        const bool over = warp ? warp_over(other, k) : !warp_over(k, other);
        return over ? 1.0f : -1.0f;
      };
      return c(k0) + (c(k0 + 1) - c(k0)) * smooth01(t - float(k0));
    };
    SurfacePoint best{floor_, {}};
    bool any = false;
    if (std::abs(u) < half) {
      const float p = std::sqrt(1.0f - (u / half) * (u / half));
      const float h = lift_ * lift_along(gy, i, true) + crown_ * p + ridges(y, u / half) * p;
      best = {h, yarn_color(o_.warp_color, i, 11, y, u * s_)};
      any = true;
    }
    if (std::abs(v) < half) {
      const float p = std::sqrt(1.0f - (v / half) * (v / half));
      const float h = lift_ * lift_along(gx, j, false) + crown_ * p + ridges(x, v / half) * p;
      if (!any || h > best.height) best = {h, yarn_color(o_.weft_color, j, 23, x, v * s_)};
      any = true;
    }
    if (!any) best.albedo = 0.5f * glm::min(o_.warp_color, o_.weft_color);  // looking through the gap
    return best;
  }

  // Stockinette: columns (wales) of V-shaped stitches, one yarn per course; each stitch's
  // two legs run from the top corners to the centre of the bottom and dip at both ends,
  // where they pass under the neighbouring courses' loops.
  [[nodiscard]] SurfacePoint knit(float x, float y) const {
    const float course = 0.75f * s_;
    const float gx = x / s_, gy = y / course;
    const std::int64_t i = floor_int(gx), j = floor_int(gy);
    const float u = gx - float(i) - 0.5f, t = gy - float(j);
    SurfacePoint best{floor_, {}};
    bool any = false;
    constexpr float kTop = -0.25f, kLength = 1.5f, kWidth = 0.26f;
    for (int dj = -1; dj <= 1; ++dj) {
      const float tt = t - float(dj);
      if (tt < kTop || tt > kTop + kLength) continue;
      const float along = (tt - kTop) / kLength;  // 0 at the top corner, 1 at the bottom
      for (float side : {-1.0f, 1.0f}) {
        const float centre = side * (0.42f - 0.40f * along);
        const float du = (u - centre) / kWidth;
        if (std::abs(du) >= 1.0f) continue;
        const float p = std::sqrt(1.0f - du * du);
        const float rise = std::sin(pi * along);
        const float h = lift_ * (2.0f * rise - 1.0f) + crown_ * p * (0.4f + 0.6f * rise) +
                        ridges(along * kLength * course + side * 3.0f, du) * p;
        if (!any || h > best.height) {
          const std::int64_t yarn = j + dj;
          best = {h, yarn_color(o_.warp_color, yarn, 37, along * kLength * course + float(i) * 7.0f, du * kWidth * s_)};
          any = true;
        }
      }
    }
    if (!any) best.albedo = 0.4f * o_.warp_color;
    return best;
  }

  const SyntheticOptions& o_;
  float s_ = 1.0f, crown_ = 0.0f, lift_ = 0.0f, floor_ = 0.0f;
};

// ---- shading ----------------------------------------------------------------------------

float smith_lambda(float cos_theta, float alpha2) {
  const float c2 = std::max(cos_theta * cos_theta, 1e-12f);
  return 0.5f * (-1.0f + std::sqrt(1.0f + alpha2 * (1.0f - c2) / c2));
}
float ggx_d(float n_dot_h, float alpha2) {
  if (n_dot_h <= 0.0f) return 0.0f;
  const float k = n_dot_h * n_dot_h * (alpha2 - 1.0f) + 1.0f;
  return alpha2 / (pi * k * k);
}
float schlick(float f0, float v_dot_h) {
  const float m = 1.0f - std::clamp(v_dot_h, 0.0f, 1.0f);
  return f0 + (1.0f - f0) * (m * m) * (m * m) * m;
}

// The height grid: cells of 1/subsamples texels, `margin` cells around the texel area.
struct HeightGrid {
  std::size_t width = 0, height = 0, margin = 0, subsamples = 1;
  std::vector<float> h;
  float lowest = 0.0f, highest = 0.0f;
  [[nodiscard]] float at(std::size_t i, std::size_t j) const { return h[j * width + i]; }
  // Bilinear, clamped to the grid; (gx, gy) in cell units with cell centres at integers.
  [[nodiscard]] float bilinear(float gx, float gy) const {
    gx = std::clamp(gx, 0.0f, float(width - 1)), gy = std::clamp(gy, 0.0f, float(height - 1));
    const auto i = std::min<std::size_t>(std::size_t(gx), width - 2), j = std::min<std::size_t>(std::size_t(gy), height - 2);
    const float tx = gx - float(i), ty = gy - float(j);
    const float a = at(i, j), b = at(i + 1, j), c = at(i, j + 1), d = at(i + 1, j + 1);
    return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
  }
};

// Soft visibility of grid point (i, j) toward unit direction d: 1 unoccluded, falling to 0
// as the height field rises `softness` above the ray.
float visibility(const HeightGrid& grid, std::size_t i, std::size_t j, const vec3& d, float softness, float max_distance) {
  const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - d.z * d.z));
  if (sin_theta < 1e-4f) return 1.0f;
  const float rise = d.z / sin_theta;  // height gained per texel travelled
  const float h0 = grid.at(i, j) + 0.05f * softness;
  if (grid.highest <= h0) return 1.0f;
  const float distance = std::min(max_distance, (grid.highest - h0) / std::max(rise, 1e-6f));
  const float cells = float(grid.subsamples);
  const float step = 0.5f / cells;  // half a cell, in texels
  const float hx = d.x / sin_theta, hy = d.y / sin_theta;
  float occlusion = 0.0f;
  for (float s = step; s <= distance; s += step) {
    const float hq = grid.bilinear(float(i) + hx * s * cells, float(j) + hy * s * cells);
    occlusion = std::max(occlusion, (hq - (h0 + rise * s)) / softness);
    if (occlusion >= 1.0f) return 0.0f;
  }
  return 1.0f - occlusion;
}

Result<void> check(const SyntheticOptions& o) {
  if (o.width == 0 || o.height == 0)
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: size {} x {} texels (both must be at least 1)", o.width, o.height);
  if (o.lights.empty() || o.views.empty())
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: {} lights and {} views (both must be at least 1)",
                o.lights.size(), o.views.size());
  // The samples alone (RGB floats for every texel and direction pair) must fit in half the
  // machine's memory: 4096 x 4096 texels at 81 x 81 directions would be 1.2 TiB.
  const double per_texel = double(o.lights.size()) * double(o.views.size()) * 3.0 * sizeof(float);
  const double bytes = double(o.width) * double(o.height) * per_texel;
  const double memory = double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGE_SIZE));
  if (memory > 0.0 && bytes > 0.5 * memory) {
    const auto side = std::uint64_t(std::sqrt(0.5 * memory / per_texel));
    return fail(ErrorKind::InvalidArgument,
                "synthetic BTF: {} x {} texels at {} x {} directions is {:.1f} GiB of samples, more than half of this "
                "machine's {:.1f} GiB of memory (at most about {} x {} texels)",
                o.width, o.height, o.lights.size(), o.views.size(), bytes / 1073741824.0, memory / 1073741824.0, side, side);
  }
  for (const auto* set : {&o.lights, &o.views})
    for (std::size_t i = 0; i < set->size(); ++i) {
      const Direction d = (*set)[i];
      if (!(d.theta >= 0.0f && d.theta <= 0.5f * pi + 1e-6f) || !std::isfinite(d.phi))
        return fail(ErrorKind::InvalidArgument, "synthetic BTF: {} {} ({}) is not in the upper hemisphere",
                    set == &o.lights ? "light" : "view", i, describe(d));
    }
  auto positive = [](float v) { return std::isfinite(v) && v > 0.0f; };
  auto unit = [](float v) { return v >= 0.0f && v <= 1.0f; };
  if (!positive(o.yarn_spacing)) return fail(ErrorKind::InvalidArgument, "synthetic BTF: yarn_spacing {} must be > 0", o.yarn_spacing);
  if (!(o.yarn_width > 0.0f && o.yarn_width <= 1.0f))
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: yarn_width {} must be in (0, 1]", o.yarn_width);
  if (!(o.relief >= 0.0f && o.relief <= 4.0f))
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: relief {} must be in [0, 4]", o.relief);
  if (!unit(o.fibre_detail)) return fail(ErrorKind::InvalidArgument, "synthetic BTF: fibre_detail {} must be in [0, 1]", o.fibre_detail);
  if (!unit(o.color_jitter)) return fail(ErrorKind::InvalidArgument, "synthetic BTF: color_jitter {} must be in [0, 1]", o.color_jitter);
  if (!unit(o.albedo_noise)) return fail(ErrorKind::InvalidArgument, "synthetic BTF: albedo_noise {} must be in [0, 1]", o.albedo_noise);
  if (!unit(o.cavity_darkening))
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: cavity_darkening {} must be in [0, 1]", o.cavity_darkening);
  if (!(o.roughness >= 0.01f && o.roughness <= 1.0f))
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: roughness {} must be in [0.01, 1]", o.roughness);
  if (!unit(o.specular)) return fail(ErrorKind::InvalidArgument, "synthetic BTF: specular {} must be in [0, 1]", o.specular);
  for (const vec3& c : {o.warp_color, o.weft_color})
    for (int k = 0; k < 3; ++k)
      if (!unit(c[k]))
        return fail(ErrorKind::InvalidArgument, "synthetic BTF: colour ({}, {}, {}) must be in [0, 1]", c.r, c.g, c.b);
  if (o.subsamples == 0 || o.subsamples > 16)
    return fail(ErrorKind::InvalidArgument, "synthetic BTF: subsamples {} must be in [1, 16]", o.subsamples);
  return {};
}

}  // namespace

constexpr EnumNames<Weave, 3> weave_names{{{Weave::Plain, "plain"}, {Weave::Twill, "twill"}, {Weave::Knit, "knit"}}};

std::string_view to_string(Weave weave) { return enum_name(weave_names, weave); }
Result<Weave> parse_weave(std::string_view text) { return enum_from_name(weave_names, text, "weave"); }

vec3 microfacet_reflectance(const vec3& albedo, float roughness, float specular, const vec3& light, const vec3& view) {
  const vec3 l = glm::normalize(light), v = glm::normalize(view);
  if (l.z <= 0.0f || v.z <= 0.0f) return vec3(0.0f);
  const float a2 = roughness * roughness * roughness * roughness;
  const vec3 h = glm::normalize(l + v);
  const float spec = ggx_d(h.z, a2) * schlick(specular, glm::dot(v, h)) /
                     (1.0f + smith_lambda(l.z, a2) + smith_lambda(v.z, a2)) / (4.0f * l.z * v.z);
  return (albedo / pi + vec3(spec)) * l.z;
}

Result<Btf> synthetic_btf(const SyntheticOptions& o) {
  WEFT_TRY_VOID(check(o));
  const auto start = std::chrono::steady_clock::now();
  const Fabric fabric(o);
  const std::size_t S = o.subsamples, L = o.lights.size(), V = o.views.size();
  const float alpha2 = o.roughness * o.roughness * o.roughness * o.roughness;
  const float range = fabric.highest() - fabric.lowest();
  const float softness = std::max(0.06f * range, 1e-3f);

  // Shadow rays travel at most until they clear the highest point (or 3 yarn spacings at
  // grazing angles); the grid's margin holds that far.
  float max_theta = 0.0f;
  for (const auto* set : {&o.lights, &o.views})
    for (auto d : *set) max_theta = std::max(max_theta, d.theta);
  const float max_distance = 3.0f * o.yarn_spacing;
  const float reach = std::min(max_distance, range * std::tan(std::min(max_theta, 0.5f * pi - 1e-3f)));
  HeightGrid grid;
  grid.subsamples = S;
  grid.margin = (static_cast<std::size_t>(std::ceil(reach)) + 2) * S;
  grid.width = o.width * S + 2 * grid.margin;
  grid.height = o.height * S + 2 * grid.margin;
  grid.h.resize(grid.width * grid.height);
  auto position = [&](std::size_t g) { return (float(g) - float(grid.margin) + 0.5f) / float(S); };
  cluster::parallel_for(grid.height, o.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j)
      for (std::size_t i = 0; i < grid.width; ++i) grid.h[j * grid.width + i] = fabric.at(position(i), position(j)).height;
  });
  grid.lowest = *std::ranges::min_element(grid.h);
  grid.highest = *std::ranges::max_element(grid.h);
  const float height_span = grid.highest - grid.lowest;

  std::vector<vec3> lights(L), views(V);
  for (std::size_t l = 0; l < L; ++l) lights[l] = to_vector(o.lights[l]);
  for (std::size_t v = 0; v < V; ++v) views[v] = to_vector(o.views[v]);
  // Per pair: the half vector and Fresnel do not depend on the surface point.
  std::vector<vec3> halfway(L * V);
  std::vector<float> fresnel(L * V);
  for (std::size_t l = 0; l < L; ++l)
    for (std::size_t v = 0; v < V; ++v) {
      const vec3 sum = lights[l] + views[v];
      const vec3 h = glm::length(sum) > 1e-6f ? glm::normalize(sum) : vec3(0, 0, 1);
      halfway[l * V + v] = h;
      fresnel[l * V + v] = schlick(o.specular, glm::dot(views[v], h));
    }

  Btf btf{o.width, o.height, o.lights, o.views, {}};
  btf.rgb.assign(btf.texels() * btf.abrdf_floats(), 0.0f);
  const double work = double(btf.texels()) * double(L * V) * double(S * S);
  const bool verbose = work > 2e7;
  std::atomic<std::size_t> done{0};
  std::atomic<int> reported{0};
  if (verbose)
    log::info(weft::format("synthetic BTF ({}, {} x {} texels, {} x {} directions, {} MB): generating", to_string(o.weave),
                           o.width, o.height, L, V, btf.rgb.size() * sizeof(float) >> 20));

  cluster::parallel_for(btf.texels(), o.threads, [&](std::size_t begin, std::size_t end) {
    const std::size_t P = S * S;
    std::vector<vec3> normal(P), albedo(P);
    std::vector<float> cos_l(P * L), lambda_l(P * L), cos_v(P * V), lambda_v(P * V), weight_v(P * V), total_v(V);
    for (std::size_t t = begin; t < end; ++t) {
      const std::size_t x = t % o.width, y = t / o.width;
      for (std::size_t p = 0; p < P; ++p) {
        const std::size_t gi = grid.margin + x * S + p % S, gj = grid.margin + y * S + p / S;
        const float dhdx = (grid.at(gi + 1, gj) - grid.at(gi - 1, gj)) * 0.5f * float(S);
        const float dhdy = (grid.at(gi, gj + 1) - grid.at(gi, gj - 1)) * 0.5f * float(S);
        const vec3 n = glm::normalize(vec3(-dhdx, -dhdy, 1.0f));
        normal[p] = n;
        const SurfacePoint sp = fabric.at(position(gi), position(gj));
        const float depth = height_span > 0.0f ? (grid.highest - grid.at(gi, gj)) / height_span : 0.0f;
        albedo[p] = glm::clamp(sp.albedo * (1.0f - o.cavity_darkening * depth), 0.0f, 1.0f);
        for (std::size_t l = 0; l < L; ++l) {
          const float c = glm::dot(n, lights[l]);
          const float vis = o.shadowing && c > 0.0f ? visibility(grid, gi, gj, lights[l], softness, max_distance) : 1.0f;
          cos_l[p * L + l] = c > 0.0f ? c * vis : 0.0f;  // shadowing folded into the cosine
          lambda_l[p * L + l] = smith_lambda(c, alpha2);
        }
        for (std::size_t v = 0; v < V; ++v) {
          const float c = glm::dot(n, views[v]);
          const float mask = o.shadowing && c > 0.0f ? visibility(grid, gi, gj, views[v], softness, max_distance) : 1.0f;
          cos_v[p * V + v] = c > 0.0f ? c : 0.0f;
          lambda_v[p * V + v] = smith_lambda(c, alpha2);
          // Projected area toward the view of the point's surface element (dA = dx dy / n_z).
          // Masking scales the contribution but not the normalisation: hidden points darken.
          weight_v[p * V + v] = c > 0.0f ? c / n.z : 0.0f;
          total_v[v] = (p == 0 ? 0.0f : total_v[v]) + weight_v[p * V + v];
          weight_v[p * V + v] *= mask;
        }
      }
      float* out = btf.rgb.data() + t * btf.abrdf_floats();
      for (std::size_t l = 0; l < L; ++l)
        for (std::size_t v = 0; v < V; ++v) {
          vec3 sum(0.0f);
          const vec3 h = halfway[l * V + v];
          if (total_v[v] > 0.0f) {
            for (std::size_t p = 0; p < P; ++p) {
              const float cl = cos_l[p * L + l], cv = cos_v[p * V + v], w = weight_v[p * V + v];
              if (cl <= 0.0f || cv <= 0.0f || w <= 0.0f) continue;
              const float d = ggx_d(glm::dot(normal[p], h), alpha2);
              // cl carries the shadowing; the specular term divides by the plain cosine.
              const float geometric_cl = glm::dot(normal[p], lights[l]);
              const float g = 1.0f / (1.0f + lambda_l[p * L + l] + lambda_v[p * V + v]);
              const float spec = d * g * fresnel[l * V + v] / (4.0f * geometric_cl * cv);
              sum += (albedo[p] / pi + vec3(spec)) * (cl * w);
            }
            sum /= total_v[v];
          }
          out[(l * V + v) * 3 + 0] = sum.r;
          out[(l * V + v) * 3 + 1] = sum.g;
          out[(l * V + v) * 3 + 2] = sum.b;
        }
      if (verbose) {
        const std::size_t finished = ++done;
        const int decile = int(finished * 10 / btf.texels());
        int seen = reported.load();
        while (decile > seen && !reported.compare_exchange_weak(seen, decile)) {
        }
        if (decile > seen && decile < 10) {
          const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          log::info(weft::format("synthetic BTF: {}% ({} / {} texels), {:.1f} s, ETA {:.1f} s", decile * 10, finished,
                                 btf.texels(), elapsed, elapsed * (double(btf.texels()) / double(finished) - 1.0)));
        }
      }
    }
  });
  if (verbose)
    log::info(weft::format("synthetic BTF: done in {:.1f} s",
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
  return btf;
}

}  // namespace weft::btf
