// Brute-force subsurface scattering, what the LUT is measured against: on an exact sphere
// (a 1-D quadrature per Gaussian after the closed-form azimuthal integral) and on a triangle
// mesh (every shaded vertex gathers from adaptively split triangles around it).
module;
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <expected>
#include <limits>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>
#include <glm/glm.hpp>
module weft.pass.skin_sss;

namespace weft::skin {

namespace {

constexpr double kPi = 3.14159265358979323846;

// ∫_0^{2π} max(a + b cos φ, 0) dφ for b >= 0.
double azimuthal(double a, double b) {
  if (b <= std::abs(a)) return a > 0.0 ? 2.0 * kPi * a : 0.0;
  const double ratio = std::clamp(-a / b, -1.0, 1.0);
  const double phi0 = std::acos(ratio);
  return 2.0 * (a * phi0 + b * std::sqrt(std::max(0.0, 1.0 - ratio * ratio)));
}

// The Gaussian's normalisation relative to the planar one (the sphere integral is written
// for planar Gaussians; ring ones are sqrt(2πv) times larger).
double relative_normalisation(double v, Normalization n) {
  return n == Normalization::Planar ? 1.0 : std::sqrt(2.0 * kPi * v);
}

}  // namespace

dvec3 sphere_reference(double cos_theta, double radius_mm, ProfileConvention convention, std::uint32_t samples) {
  const double c = std::clamp(std::isnan(cos_theta) ? 1.0 : cos_theta, -1.0, 1.0);
  const double flat = std::max(c, 0.0);
  if (std::isnan(radius_mm) || std::isinf(radius_mm)) return dvec3(flat);
  const double r = std::max(radius_mm, 1e-9);
  const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
  const std::uint32_t n = std::max<std::uint32_t>(samples, 16);
  dvec3 numerator(0.0), denominator(0.0);
  for (const ProfileGaussian& g : skin_profile()) {
    const double v = g.variance * convention.variance_scale;
    if (!(v > 0.0)) continue;
    const double t_max = 2.0 * r * r / v;
    const double s_max = -std::expm1(-t_max);  // 1 - exp(-T): the Gaussian's mass on the sphere
    if (!(s_max > 0.0)) continue;
    const double ds = s_max / n;
    double sum = 0.0;
    for (std::uint32_t k = 0; k < n; ++k) {
      const double t = -std::log1p(-(k + 0.5) * ds);
      const double cos_a = std::clamp(1.0 - v * t / (r * r), -1.0, 1.0);
      const double sin_a = std::sqrt(std::max(0.0, 1.0 - cos_a * cos_a));
      sum += azimuthal(cos_a * c, sin_a * s);
    }
    const double area_integral = sum * ds / (2.0 * kPi);
    const dvec3 w = g.weight * relative_normalisation(v, convention.normalization);
    numerator += w * area_integral;
    denominator += w * s_max;
  }
  dvec3 out;
  for (int ch = 0; ch < 3; ++ch)
    out[ch] = denominator[ch] > 0.0 ? std::clamp(numerator[ch] / denominator[ch], 0.0, 1.0) : flat;
  return out;
}

Result<std::vector<vec3>> mesh_reference(const scene::Mesh& mesh, const MeshReferenceOptions& options) {
  const std::size_t n = mesh.positions.size();
  if (n == 0 || mesh.indices.size() < 3 || mesh.indices.size() % 3 != 0)
    return fail(ErrorKind::InvalidArgument, "mesh reference: mesh '{}' has no triangles", mesh.name);
  if (mesh.normals.size() != n)
    return fail(ErrorKind::InvalidArgument, "mesh reference: mesh '{}' needs one normal per vertex", mesh.name);
  for (std::uint32_t i : mesh.indices)
    if (i >= n) return fail(ErrorKind::InvalidArgument, "mesh reference: mesh '{}' has index {} >= {}", mesh.name, i, n);
  if (!(options.mm_per_unit > 0.0) || !std::isfinite(options.mm_per_unit))
    return fail(ErrorKind::InvalidArgument, "mesh reference: mm_per_unit must be positive, got {}", options.mm_per_unit);
  const double light_len = glm::length(glm::dvec3(options.towards_light));
  if (!(light_len > 0.0) || !std::isfinite(light_len))
    return fail(ErrorKind::InvalidArgument, "mesh reference: towards_light must be a non-zero vector");
  const glm::dvec3 light = glm::dvec3(options.towards_light) / light_len;

  struct Term {
    double v;
    dvec3 weight;
  };
  std::vector<Term> terms;
  double widest = 0.0;
  for (const ProfileGaussian& g : skin_profile()) {
    const double v = g.variance * options.convention.variance_scale;
    if (!(v > 0.0)) continue;
    const double norm = options.convention.normalization == Normalization::Planar ? 1.0 / (2.0 * kPi * v)
                                                                                   : 1.0 / std::sqrt(2.0 * kPi * v);
    terms.push_back({v, g.weight * norm});
    widest = std::max(widest, v);
  }
  const double cutoff = 6.0 * std::sqrt(widest);
  const double min_cell = std::max(options.min_cell_mm, 1e-6);
  const double refine = std::max(options.refine, 1.0);

  const std::size_t triangle_count = mesh.indices.size() / 3;
  std::vector<glm::dvec3> pos(n), nrm(n);
  for (std::size_t i = 0; i < n; ++i) {
    pos[i] = glm::dvec3(mesh.positions[i]) * options.mm_per_unit;
    const glm::dvec3 nv(mesh.normals[i]);
    const double len = glm::length(nv);
    nrm[i] = len > 0.0 && std::isfinite(len) ? nv / len : glm::dvec3(0.0);
  }

  // Triangles binned into a uniform grid of cutoff-sized cells by their bounding boxes.
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const auto& p : pos) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const double cell = cutoff;
  const glm::ivec3 dims = glm::clamp(glm::ivec3(glm::floor((hi - lo) / cell)) + 1, glm::ivec3(1), glm::ivec3(1024));
  const auto cell_of = [&](const glm::dvec3& p) {
    return glm::clamp(glm::ivec3(glm::floor((p - lo) / cell)), glm::ivec3(0), dims - 1);
  };
  const auto key = [&](glm::ivec3 c) { return (std::int64_t(c.z) * dims.y + c.y) * dims.x + c.x; };
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> bins;
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const auto* idx = &mesh.indices[t * 3];
    glm::dvec3 a = glm::min(glm::min(pos[idx[0]], pos[idx[1]]), pos[idx[2]]);
    glm::dvec3 b = glm::max(glm::max(pos[idx[0]], pos[idx[1]]), pos[idx[2]]);
    const glm::ivec3 c0 = cell_of(a), c1 = cell_of(b);
    for (int z = c0.z; z <= c1.z; ++z)
      for (int y = c0.y; y <= c1.y; ++y)
        for (int x = c0.x; x <= c1.x; ++x) bins[key({x, y, z})].push_back(std::uint32_t(t));
  }

  std::vector<vec3> out(n);
  std::atomic<std::size_t> next{0};
  const std::uint32_t thread_count =
      std::max(1u, std::min<std::uint32_t>(options.threads ? options.threads : std::thread::hardware_concurrency(),
                                           std::uint32_t(std::min<std::size_t>(n, 1024))));
  // A large mesh takes minutes (about 6 ms per vertex on one core): the first worker logs
  // progress and an estimate every 10 s.
  std::atomic<std::size_t> done{0};
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  const auto report = [&] {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_report < std::chrono::seconds(10)) return;
    last_report = now;
    const std::size_t finished = done.load();
    const double elapsed = std::chrono::duration<double>(now - start).count();
    const double left = finished > 0 ? elapsed * double(n - finished) / double(finished) : 0.0;
    log::info(weft::format("skin mesh reference: {} of {} vertices ({:.0f} %), {:.0f} s elapsed, about {:.0f} s left",
                           finished, n, 100.0 * double(finished) / double(n), elapsed, left));
  };
  auto worker = [&](bool reports) {
    std::vector<std::uint32_t> stamp(triangle_count, ~0u);
    struct Cell {
      glm::dvec3 p[3], nv[3];
      int depth;
    };
    std::vector<Cell> stack;
    std::vector<double> num(terms.size()), den(terms.size());
    for (std::size_t v = next.fetch_add(16); v < n; v = next.fetch_add(16)) {
      for (std::size_t vi = v; vi < std::min(n, v + 16); ++vi) {
        const glm::dvec3 p = pos[vi];
        std::fill(num.begin(), num.end(), 0.0);
        std::fill(den.begin(), den.end(), 0.0);
        const glm::ivec3 c = cell_of(p);
        for (int z = std::max(c.z - 1, 0); z <= std::min(c.z + 1, dims.z - 1); ++z)
          for (int y = std::max(c.y - 1, 0); y <= std::min(c.y + 1, dims.y - 1); ++y)
            for (int x = std::max(c.x - 1, 0); x <= std::min(c.x + 1, dims.x - 1); ++x) {
              auto it = bins.find(key({x, y, z}));
              if (it == bins.end()) continue;
              for (std::uint32_t t : it->second) {
                if (stamp[t] == vi) continue;
                stamp[t] = std::uint32_t(vi);
                const auto* idx = &mesh.indices[std::size_t(t) * 3];
                stack.push_back({{pos[idx[0]], pos[idx[1]], pos[idx[2]]}, {nrm[idx[0]], nrm[idx[1]], nrm[idx[2]]}, 0});
                while (!stack.empty()) {
                  const Cell k = stack.back();
                  stack.pop_back();
                  const glm::dvec3 centre = (k.p[0] + k.p[1] + k.p[2]) / 3.0;
                  const double size = std::max({glm::length(k.p[1] - k.p[0]), glm::length(k.p[2] - k.p[1]),
                                                 glm::length(k.p[0] - k.p[2])});
                  const double dist = glm::length(p - centre);
                  const double closest = dist - size;
                  if (closest > cutoff) continue;
                  if (size > std::max(min_cell, closest / refine) && k.depth < 16) {
                    const glm::dvec3 m01 = 0.5 * (k.p[0] + k.p[1]), m12 = 0.5 * (k.p[1] + k.p[2]), m20 = 0.5 * (k.p[2] + k.p[0]);
                    const glm::dvec3 n01 = 0.5 * (k.nv[0] + k.nv[1]), n12 = 0.5 * (k.nv[1] + k.nv[2]), n20 = 0.5 * (k.nv[2] + k.nv[0]);
                    const int d = k.depth + 1;
                    stack.push_back({{k.p[0], m01, m20}, {k.nv[0], n01, n20}, d});
                    stack.push_back({{m01, k.p[1], m12}, {n01, k.nv[1], n12}, d});
                    stack.push_back({{m20, m12, k.p[2]}, {n20, n12, k.nv[2]}, d});
                    stack.push_back({{m01, m12, m20}, {n01, n12, n20}, d});
                    continue;
                  }
                  const double area = 0.5 * glm::length(glm::cross(k.p[1] - k.p[0], k.p[2] - k.p[0]));
                  if (!(area > 0.0)) continue;
                  const glm::dvec3 ns = k.nv[0] + k.nv[1] + k.nv[2];
                  const double ns_len = glm::length(ns);
                  const double irradiance = ns_len > 0.0 ? std::max(glm::dot(ns, light) / ns_len, 0.0) : 0.0;
                  const double d2 = dist * dist;
                  for (std::size_t i = 0; i < terms.size(); ++i) {
                    if (d2 > 40.0 * terms[i].v) continue;
                    const double g = std::exp(-d2 / (2.0 * terms[i].v)) * area;
                    num[i] += g * irradiance;
                    den[i] += g;
                  }
                }
              }
            }
        dvec3 top(0.0), bottom(0.0);
        for (std::size_t i = 0; i < terms.size(); ++i) {
          top += terms[i].weight * num[i];
          bottom += terms[i].weight * den[i];
        }
        const double flat = std::max(glm::dot(nrm[vi], light), 0.0);
        vec3 result;
        for (int ch = 0; ch < 3; ++ch)
          result[ch] = float(bottom[ch] > 0.0 ? std::clamp(top[ch] / bottom[ch], 0.0, 1.0) : flat);
        out[vi] = result;
      }
      done += std::min(n, v + 16) - v;
      if (reports) report();
    }
  };
  if (thread_count <= 1) {
    worker(true);
  } else {
    std::vector<std::thread> pool;
    for (std::uint32_t t = 0; t < thread_count; ++t) pool.emplace_back(worker, t == 0);
    for (auto& th : pool) th.join();
  }
  return out;
}

}  // namespace weft::skin
