// weft-bench-skin: how close the pre-integrated skin LUT comes to brute-force subsurface
// scattering, as a function of curvature, integration range, profile convention, LUT size
// and ring sample count; how long a LUT takes to generate; what SkinSSSPass costs per frame
// against plain Lambert + GGX on the same scene; and screen-space against per-vertex
// curvature. Prints markdown tables (docs/skin.md quotes them).
//
//   build/bin/weft-bench-skin [sections...] [--runs N] [--head PATH] [--size WxH]
//   sections: conventions range size samples time mesh frame curvature image (default: all)
//
// Error metric: RMSE over θ in [0°, 180°] (2° steps) and the three channels, of D(θ, r)
// against sphere_reference (a sphere of radius r lit by a distant light; d'Eon's planar
// profile, no shadowing). Times are medians over --runs runs of steady_clock.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <sys/resource.h>
#include <weft/args.h>
import weft.core;
import weft.feature;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.builtin_features;
import weft.pass.skin_sss;
import weft.bench.device;

using namespace weft;
using skin::dvec3;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kPi = 3.14159265358979323846;
const double kCurvatures[] = {0.01, 0.02, 0.05, 0.1, 0.2, 0.33, 0.5, 0.75, 1.0};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// CPU time of the whole process (every thread, llvmpipe's rasteriser threads included), in ms:
// on a shared machine it does not count the time other processes held the cores.
double process_cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e3;
}
double min_of(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end()); }

struct Options {
  std::set<std::string> sections;
  int runs = 5;
  std::string head;
  std::uint32_t width = 640, height = 480;
  bool wants(const char* s) const { return sections.empty() || sections.contains(s); }
};

// The sphere reference on the 2° grid, per curvature (computed once, shared by the tables).
struct ReferenceGrid {
  std::vector<double> theta;
  std::vector<std::vector<dvec3>> values;  // [curvature][theta]
};
const ReferenceGrid& reference_grid() {
  static ReferenceGrid grid = [] {
    ReferenceGrid g;
    for (int i = 0; i <= 90; ++i) g.theta.push_back(kPi * i / 90.0);
    for (double k : kCurvatures) {
      std::vector<dvec3> row;
      for (double t : g.theta) row.push_back(skin::sphere_reference(std::cos(t), 1.0 / k, skin::physical_convention, 8192));
      g.values.push_back(std::move(row));
    }
    return g;
  }();
  return grid;
}

struct ErrorStats {
  double rmse = 0.0, max = 0.0;
};

template <class Fn>
ErrorStats error_at(std::size_t curvature_index, Fn value, double theta_lo = 0.0, double theta_hi = kPi) {
  const auto& g = reference_grid();
  double se = 0.0, worst = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < g.theta.size(); ++i) {
    if (g.theta[i] < theta_lo - 1e-9 || g.theta[i] > theta_hi + 1e-9) continue;
    const dvec3 d = value(std::cos(g.theta[i]));
    const dvec3& ref = g.values[curvature_index][i];
    for (int c = 0; c < 3; ++c) {
      const double e = d[c] - ref[c];
      se += e * e;
      worst = std::max(worst, std::abs(e));
      ++n;
    }
  }
  return {std::sqrt(se / n), worst};
}

void conventions_table() {
  struct Named {
    const char* name;
    skin::ProfileConvention c;
  };
  const Named conventions[] = {{"planar, v×1 (thesis eq. 2.2)", skin::thesis_convention},
                               {"ring, v×1.414 (Penner's listing)", skin::penner_convention},
                               {"ring, v×1", {skin::Normalization::Ring, 1.0}},
                               {"planar, v×1.414", {skin::Normalization::Planar, 1.414}}};
  const skin::IntegrationRange ranges[] = {skin::IntegrationRange::Penner, skin::IntegrationRange::Adaptive,
                                           skin::IntegrationRange::Full};
  std::printf("\n### Profile convention against the sphere reference (RMSE over θ and RGB)\n\n");
  std::printf("Per curvature with the adaptive range; the last rows are means over the nine curvatures "
              "(1/r = 0.01 … 1 mm⁻¹) for each range.\n\n");
  std::printf("| 1/r (1/mm) |");
  for (const auto& c : conventions) std::printf(" %s |", c.name);
  std::printf("\n|---:|");
  for (std::size_t i = 0; i < std::size(conventions); ++i) std::printf("---:|");
  std::printf("\n");
  std::vector<std::vector<double>> sums(std::size(ranges), std::vector<double>(std::size(conventions), 0.0));
  for (std::size_t k = 0; k < std::size(kCurvatures); ++k) {
    std::string row = weft::format("| {:.2f} |", kCurvatures[k]);
    for (std::size_t r = 0; r < std::size(ranges); ++r)
      for (std::size_t i = 0; i < std::size(conventions); ++i) {
        const skin::RingOptions o{ranges[r], conventions[i].c, 1024};
        const auto e = error_at(k, [&](double c) { return skin::integrate_ring(c, 1.0 / kCurvatures[k], o); });
        sums[r][i] += e.rmse;
        if (ranges[r] == skin::IntegrationRange::Adaptive) row += weft::format(" {:.4f} |", e.rmse);
      }
    std::printf("%s\n", row.c_str());
  }
  for (std::size_t r = 0; r < std::size(ranges); ++r) {
    std::printf("| **mean, %s range** |", std::string(skin::to_string(ranges[r])).c_str());
    for (double s : sums[r]) std::printf(" **%.4f** |", s / std::size(kCurvatures));
    std::printf("\n");
  }
}

void range_table() {
  std::printf("\n### Integration range against the sphere reference (default convention: %s, v×%.3g)\n\n",
              std::string(skin::to_string(skin::default_convention.normalization)).c_str(),
              skin::default_convention.variance_scale);
  std::printf("RMSE over all θ | RMSE near the terminator (60°–120°) | largest error, per range.\n\n");
  std::printf("| 1/r (1/mm) | r (mm) | Penner | adaptive | full | Penner 60–120° | adaptive 60–120° | full 60–120° | Penner max | adaptive max | full max |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  const skin::IntegrationRange ranges[] = {skin::IntegrationRange::Penner, skin::IntegrationRange::Adaptive,
                                           skin::IntegrationRange::Full};
  double sum[3] = {0, 0, 0}, sum_band[3] = {0, 0, 0};
  for (std::size_t k = 0; k < std::size(kCurvatures); ++k) {
    ErrorStats all[3], band[3];
    for (int i = 0; i < 3; ++i) {
      const skin::RingOptions o{ranges[i], skin::default_convention, 1024};
      auto fn = [&](double c) { return skin::integrate_ring(c, 1.0 / kCurvatures[k], o); };
      all[i] = error_at(k, fn);
      band[i] = error_at(k, fn, kPi / 3, 2 * kPi / 3);
      sum[i] += all[i].rmse;
      sum_band[i] += band[i].rmse;
    }
    std::printf("| %.2f | %.1f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n", kCurvatures[k],
                1.0 / kCurvatures[k], all[0].rmse, all[1].rmse, all[2].rmse, band[0].rmse, band[1].rmse, band[2].rmse,
                all[0].max, all[1].max, all[2].max);
  }
  const double n = double(std::size(kCurvatures));
  std::printf("| **mean** | | **%.4f** | **%.4f** | **%.4f** | **%.4f** | **%.4f** | **%.4f** | | | |\n", sum[0] / n,
              sum[1] / n, sum[2] / n, sum_band[0] / n, sum_band[1] / n, sum_band[2] / n);

  std::printf("\nD(θ, r) at a few points (red, green, blue), reference | Penner | adaptive:\n\n");
  std::printf("| r (mm) | θ | reference | Penner | adaptive |\n|---:|---:|---|---|---|\n");
  for (double r : {1.0, 2.0, 10.0})
    for (double deg : {0.0, 90.0, 110.0, 150.0}) {
      const double c = std::cos(deg * kPi / 180.0);
      const dvec3 ref = skin::sphere_reference(c, r, skin::physical_convention, 8192);
      const dvec3 p = skin::integrate_ring(c, r, {skin::IntegrationRange::Penner, skin::default_convention, 1024});
      const dvec3 a = skin::integrate_ring(c, r, {skin::IntegrationRange::Adaptive, skin::default_convention, 1024});
      std::printf("| %.0f | %.0f° | %.3f %.3f %.3f | %.3f %.3f %.3f | %.3f %.3f %.3f |\n", r, deg, ref.x, ref.y, ref.z, p.x,
                  p.y, p.z, a.x, a.y, a.z);
    }
}

void size_table() {
  std::printf("\n### LUT size (adaptive range, 256 samples): bilinear lookups against the sphere reference and against the exact ring integral\n\n");
  std::printf("| LUT | texels | RMSE vs reference | RMSE vs exact D | max vs exact D | generation (ms) |\n|---:|---:|---:|---:|---:|---:|\n");
  for (std::uint32_t size : {16u, 32u, 64u, 128u, 256u, 512u}) {
    const auto t0 = Clock::now();
    auto lut = skin::generate_lut({.width = size, .height = size, .samples = 256});
    const double ms = ms_since(t0);
    if (!lut) {
      std::printf("| %u | error: %s |\n", size, lut.error().message.c_str());
      continue;
    }
    double se_ref = 0.0, se_exact = 0.0, worst = 0.0;
    int n = 0;
    const auto& g = reference_grid();
    for (std::size_t k = 0; k < std::size(kCurvatures); ++k)
      for (std::size_t i = 0; i < g.theta.size(); ++i) {
        const double c = std::cos(g.theta[i]);
        const vec3 got = skin::sample_diffuse(*lut, float(c), float(kCurvatures[k]));
        const dvec3 exact = skin::integrate_ring(c, 1.0 / kCurvatures[k], {.samples = 256});
        for (int ch = 0; ch < 3; ++ch) {
          se_ref += std::pow(got[ch] - g.values[k][i][ch], 2);
          se_exact += std::pow(got[ch] - exact[ch], 2);
          worst = std::max(worst, std::abs(got[ch] - exact[ch]));
          ++n;
        }
      }
    std::printf("| %u² | %u | %.4f | %.5f | %.4f | %.1f |\n", size, size * size, std::sqrt(se_ref / n), std::sqrt(se_exact / n),
                worst, ms);
  }
}

void samples_table() {
  std::printf("\n### Ring samples: D against an 8192-sample integral (adaptive range), and against the sphere reference\n\n");
  std::printf("| samples | per-Gaussian RMSE vs converged | uniform RMSE vs converged | per-Gaussian vs reference | uniform vs reference |\n|---:|---:|---:|---:|---:|\n");
  const auto& g = reference_grid();
  std::vector<std::vector<dvec3>> converged;
  for (double k : kCurvatures) {
    std::vector<dvec3> row;
    for (double t : g.theta) row.push_back(skin::integrate_ring(std::cos(t), 1.0 / k, {.samples = 8192}));
    converged.push_back(std::move(row));
  }
  for (std::uint32_t samples : {4u, 8u, 16u, 32u, 64u, 128u, 256u, 1024u}) {
    double se[2] = {0, 0}, se_ref[2] = {0, 0};
    int n = 0;
    for (std::size_t k = 0; k < std::size(kCurvatures); ++k)
      for (std::size_t i = 0; i < g.theta.size(); ++i) {
        const double c = std::cos(g.theta[i]);
        const dvec3 a = skin::integrate_ring(c, 1.0 / kCurvatures[k], {.samples = samples});
        const dvec3 b = skin::integrate_ring(c, 1.0 / kCurvatures[k], {.samples = samples, .quadrature = skin::Quadrature::Uniform});
        for (int ch = 0; ch < 3; ++ch) {
          se[0] += std::pow(a[ch] - converged[k][i][ch], 2);
          se[1] += std::pow(b[ch] - converged[k][i][ch], 2);
          se_ref[0] += std::pow(a[ch] - g.values[k][i][ch], 2);
          se_ref[1] += std::pow(b[ch] - g.values[k][i][ch], 2);
          ++n;
        }
      }
    std::printf("| %u | %.6f | %.6f | %.4f | %.4f |\n", samples, std::sqrt(se[0] / n), std::sqrt(se[1] / n),
                std::sqrt(se_ref[0] / n), std::sqrt(se_ref[1] / n));
  }
}

void time_table(int runs) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  std::printf("\n### LUT generation time, 256×256 (median of %d runs; %u hardware threads)\n\n", runs, hw);
  std::printf("Wall time, and the process's CPU time (all threads), which other processes' load does not inflate.\n\n");
  std::printf("| range | quadrature | samples | 1 thread: wall ms | 1 thread: CPU ms | %u threads: wall ms | %u threads: CPU ms |\n"
              "|---|---|---:|---:|---:|---:|---:|\n", hw, hw);
  for (auto range : {skin::IntegrationRange::Penner, skin::IntegrationRange::Adaptive})
    for (std::uint32_t samples : {64u, 256u}) {
      double ms[2], cpu[2];
      int slot = 0;
      for (std::uint32_t threads : {1u, hw}) {
        std::vector<double> t, c;
        for (int i = 0; i < runs; ++i) {
          const double c0 = process_cpu_ms();
          const auto t0 = Clock::now();
          auto lut = skin::generate_lut({.width = 256, .height = 256, .range = range, .samples = samples, .threads = threads});
          t.push_back(ms_since(t0));
          c.push_back(process_cpu_ms() - c0);
          if (!lut) std::printf("error: %s\n", lut.error().message.c_str());
        }
        ms[slot] = median(t);
        cpu[slot++] = median(c);
      }
      std::printf("| %s | per-Gaussian | %u | %.1f | %.1f | %.1f | %.1f |\n", std::string(skin::to_string(range)).c_str(),
                  samples, ms[0], cpu[0], ms[1], cpu[1]);
    }
}

std::optional<std::filesystem::path> find_head(const Options& o) {
  std::vector<std::filesystem::path> candidates;
  if (!o.head.empty()) candidates.emplace_back(o.head);
  if (const char* d = std::getenv("WEFT_SHARED_DATA")) candidates.push_back(std::filesystem::path(d) / "meshes/head/head.obj");
  candidates.emplace_back("assets/meshes/head/head.obj");
  candidates.emplace_back("../shared/data/meshes/head/head.obj");
  candidates.emplace_back("/work/shared/data/meshes/head/head.obj");
  for (const auto& c : candidates)
    if (std::filesystem::exists(c)) return c;
  return std::nullopt;
}

// The head scan is a bust: the head is 0.167 units wide and 0.222 long at the forehead, an
// adult head 150-155 by 190-195 mm, so about 900 mm per unit.
constexpr double kHeadMmPerUnit = 900.0;

void mesh_table(const Options& o) {
  std::printf("\n### On meshes: per-vertex LUT shading against the brute-force mesh reference\n\n");
  std::printf("Per vertex: LUT(N·L, the mesh's |Δn|/|Δp| curvature) against mesh_reference (every vertex gathers "
              "cos⁺ irradiance over the split triangles around it, weighted by d'Eon's planar profile). RMSE over "
              "vertices and RGB; 'exact κ' uses the analytic 1/r instead of the mesh curvature.\n\n");
  std::printf("| mesh | vertices | reference time (s) | Lambert (no scattering) | Penner | adaptive | full | adaptive, exact κ |\n|---|---:|---:|---:|---:|---:|---:|---:|\n");
  auto penner = skin::generate_lut({.range = skin::IntegrationRange::Penner});
  auto adaptive = skin::generate_lut({.range = skin::IntegrationRange::Adaptive});
  auto full = skin::generate_lut({.range = skin::IntegrationRange::Full});
  if (!penner || !adaptive || !full) return;
  const vec3 light = glm::normalize(vec3(0.6f, 0.35f, 0.7f));
  struct Bin {
    double se[3] = {0, 0, 0};
    int n = 0;
  };
  std::vector<Bin> bins(6);
  const double bin_edges[] = {0.0, 0.02, 0.05, 0.1, 0.2, 0.5, 1e30};
  auto run = [&](const std::string& name, const scene::Mesh& mesh, double mm_per_unit, std::optional<double> exact_k,
                 bool binned = false) {
    const auto t0 = Clock::now();
    auto ref = skin::mesh_reference(mesh, {.towards_light = light, .mm_per_unit = mm_per_unit});
    const double seconds = ms_since(t0) / 1000.0;
    if (!ref) {
      std::printf("| %s | error: %s |\n", name.c_str(), ref.error().message.c_str());
      return;
    }
    double se[5] = {0, 0, 0, 0, 0};
    int n = 0;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      const float nl = glm::dot(glm::normalize(mesh.normals[i]), light);
      const float k = float(mesh.curvature[i] / mm_per_unit);
      const vec3 got[5] = {vec3(std::max(nl, 0.0f)), skin::sample_diffuse(*penner, nl, k),
                           skin::sample_diffuse(*adaptive, nl, k), skin::sample_diffuse(*full, nl, k),
                           skin::sample_diffuse(*adaptive, nl, float(exact_k.value_or(k)))};
      std::size_t b = 0;
      while (b + 1 < bins.size() && k >= bin_edges[b + 1]) ++b;
      for (int c = 0; c < 3; ++c) {
        for (int j = 0; j < 5; ++j) se[j] += std::pow(got[j][c] - (*ref)[i][c], 2);
        ++n;
        if (binned) {
          for (int j = 0; j < 3; ++j) bins[b].se[j] += std::pow(got[j][c] - (*ref)[i][c], 2);
          ++bins[b].n;
        }
      }
    }
    const std::string exact = exact_k ? weft::format("{:.4f}", std::sqrt(se[4] / n)) : std::string("–");
    std::printf("| %s | %zu | %.1f | %.4f | %.4f | %.4f | %.4f | %s |\n", name.c_str(), mesh.positions.size(), seconds,
                std::sqrt(se[0] / n), std::sqrt(se[1] / n), std::sqrt(se[2] / n), std::sqrt(se[3] / n), exact.c_str());
  };
  for (double radius_mm : {2.0, 5.0, 20.0}) {
    auto sphere = scene::make_sphere(float(radius_mm), 64);
    if (sphere) run(weft::format("sphere r = {} mm", radius_mm), *sphere, 1.0, 1.0 / radius_mm);
  }
  if (auto head_path = find_head(o)) {
    auto head = scene::load_mesh(*head_path);
    if (head) run(weft::format("head scan ({} mm/unit)", kHeadMmPerUnit), *head, kHeadMmPerUnit, std::nullopt, true);
    else std::printf("| head | error: %s |\n", head.error().message.c_str());
    std::printf("\nHead scan by vertex curvature (|Δn|/|Δp|, 1/mm):\n\n| 1/r | vertices | Lambert | Penner | adaptive |\n|---|---:|---:|---:|---:|\n");
    for (std::size_t b = 0; b < bins.size(); ++b) {
      if (!bins[b].n) continue;
      const std::string label = b + 1 < bins.size() ? weft::format("{}–{}", bin_edges[b], bin_edges[b + 1])
                                                    : weft::format(">= {}", bin_edges[b]);
      std::printf("| %s | %d | %.4f | %.4f | %.4f |\n", label.c_str(), bins[b].n / 3, std::sqrt(bins[b].se[0] / bins[b].n),
                  std::sqrt(bins[b].se[1] / bins[b].n), std::sqrt(bins[b].se[2] / bins[b].n));
    }
  } else {
    std::printf("| head | skipped: no head.obj (give --head PATH or set WEFT_SHARED_DATA) | | | | | |\n");
  }
}

// ---- GPU sections ------------------------------------------------------------------------

using bench::Session;

// A row of spheres of radius 1.5, 3, 6 and 12 mm (scene units are mm), one material.
const double kSphereRadii[] = {1.5, 3.0, 6.0, 12.0};
std::string sphere_row_scene(const std::string& material, std::uint32_t w, std::uint32_t h, const char* sky = "[0.03, 0.03, 0.035]") {
  std::string meshes, objects;
  double x = 0.0;
  for (std::size_t i = 0; i < std::size(kSphereRadii); ++i) {
    const double r = kSphereRadii[i];
    x += (i ? kSphereRadii[i - 1] : 0.0) + r + 1.0;
    meshes += weft::format("{}\"s{}\": {{\"primitive\": \"sphere\", \"radius\": {}, \"segments\": 128}}", i ? ", " : "", i, r);
    objects += weft::format("{}{{\"name\": \"s{}\", \"mesh\": \"s{}\", \"material\": \"m\", \"transform\": {{\"translation\": [{}, 0, 0]}}}}",
                            i ? ", " : "", i, i, x);
  }
  return weft::format(R"({{"version": 1, "output": {{"width": {}, "height": {}}},
    "environment": {{"color": {}}},
    "lights": [{{"type": "directional", "direction": [-0.7, -0.3, -0.5], "intensity": 3.14159}}],
    "meshes": {{{}}}, "materials": {{"m": {}}}, "objects": [{}]}})",
                      w, h, sky, meshes, material, objects);
}

std::string head_scene(const std::filesystem::path& head, const std::string& material, std::uint32_t w, std::uint32_t h,
                       const char* sky = "[0.03, 0.03, 0.035]") {
  return weft::format(R"({{"version": 1, "output": {{"width": {}, "height": {}}},
    "camera": {{"position": [0.25, 0.05, 0.75], "target": [0.0, -0.07, 0.0], "fov": 35}},
    "environment": {{"color": {}}},
    "lights": [{{"type": "directional", "direction": [-0.8, -0.25, -0.45], "intensity": 3.14159}}],
    "meshes": {{"head": {{"path": "{}"}}}}, "materials": {{"m": {}}},
    "objects": [{{"name": "head", "mesh": "head", "material": "m"}}]}})",
                      w, h, sky, head.string(), material);
}

std::optional<scene::Scene> load_text(const std::string& json) {
  auto desc = scene::parse_scene(json, std::filesystem::current_path());
  if (!desc) {
    std::printf("scene error: %s\n", desc.error().message.c_str());
    return std::nullopt;
  }
  auto s = scene::load_scene(*desc);
  if (!s) {
    std::printf("scene error: %s\n", s.error().message.c_str());
    return std::nullopt;
  }
  return std::move(*s);
}

const char* kStandard = R"({"type": "standard", "base_color": [0.84, 0.6, 0.5], "roughness": 0.45})";
std::string skin_json(double mm_per_unit, const char* extra = "") {
  return weft::format(R"({{"type": "skin", "albedo": [0.84, 0.6, 0.5], "mm_per_unit": {}{}}})", mm_per_unit, extra);
}

double pass_ms(const FrameStats& stats, std::string_view name) {
  for (const auto& p : stats.passes)
    if (p.name == name) return p.gpu_ms;
  return 0.0;
}

void frame_table(Session& session, const Options& o) {
  const auto head = find_head(o);
  std::string name = head ? "head scan (8,844 vertices)" : "four spheres (no head.obj found)";
  auto standard = head ? load_text(head_scene(*head, kStandard, o.width, o.height))
                       : load_text(sphere_row_scene(kStandard, o.width, o.height));
  auto skinned = head ? load_text(head_scene(*head, skin_json(kHeadMmPerUnit), o.width, o.height))
                      : load_text(sphere_row_scene(skin_json(1.0), o.width, o.height));
  if (!standard || !skinned) return;
  auto renderer = renderer::Renderer::create(session.device);
  if (!renderer) return;
  // Warm up both (pipelines, LUT, uploads), then alternate frames so drift hits both alike.
  for (auto* s : {&*standard, &*skinned})
    if (auto f = renderer->render(*s); !f) {
      std::printf("render error: %s\n", f.error().message.c_str());
      return;
    }
  std::vector<double> std_total, std_forward, skin_total, skin_forward, skin_pass, std_cpu, skin_cpu, std_proc, skin_proc;
  for (int i = 0; i < o.runs; ++i) {
    const double c0 = process_cpu_ms();
    auto a = renderer->render(*standard);
    const double c1 = process_cpu_ms();
    auto b = renderer->render(*skinned);
    const double c2 = process_cpu_ms();
    if (!a || !b) return;
    std_proc.push_back(c1 - c0);
    skin_proc.push_back(c2 - c1);
    std_total.push_back(a->stats.gpu_total_ms);
    std_forward.push_back(pass_ms(a->stats, "forward"));
    std_cpu.push_back(a->stats.cpu_frame_ms);
    skin_total.push_back(b->stats.gpu_total_ms);
    skin_forward.push_back(pass_ms(b->stats, "forward"));
    skin_pass.push_back(pass_ms(b->stats, "skin_sss"));
    skin_cpu.push_back(b->stats.cpu_frame_ms);
  }
  std::printf("\n### Frame time: SkinSSSPass against plain Lambert + GGX, same scene, same run\n\n");
  std::printf("%s, %ux%u, key light with shadow map (medium quality: 2048²), on %s. %d frames each, "
              "alternating; GPU times from timestamps (median and fastest frame); process CPU time is every thread "
              "of the process, llvmpipe's included, so other processes' load does not inflate it.\n\n",
              name.c_str(), o.width, o.height, session.adapter.info().name.c_str(), o.runs);
  std::printf("| material | frame GPU ms (median) | frame GPU ms (fastest) | frame wall ms (median) | process CPU ms per frame (median) |\n|---|---:|---:|---:|---:|\n");
  std::printf("| standard (forward: Lambert + GGX) | %.2f | %.2f | %.2f | %.1f |\n", median(std_total), min_of(std_total),
              median(std_cpu), median(std_proc));
  std::printf("| skin (forward clears, skin_sss shades) | %.2f | %.2f | %.2f | %.1f |\n", median(skin_total),
              min_of(skin_total), median(skin_cpu), median(skin_proc));
  std::printf("\nSkin / standard: GPU time %.2f× (median), %.2f× (fastest), process CPU time %.2f×. The thesis (Unity, "
              "GTX 1660): 79 fps with its basic subsurface-scattering shader, 69 with Penner's LUT, 66 with the "
              "adaptive LUT (1.20× the frame time of the first).\n",
              median(skin_total) / median(std_total), min_of(skin_total) / min_of(std_total),
              median(skin_proc) / median(std_proc));
  auto a = renderer->render(*standard);
  auto b = renderer->render(*skinned);
  if (a && b) {
    std::printf("\nOne frame of each, per pass (llvmpipe bins draws and rasterises when a render pass ends, so "
                "per-pass timestamps move work between passes; the frame totals are what to compare):\n\n");
    std::printf("standard:\n\n%s\nskin:\n\n%s", a->stats.format_table().c_str(), b->stats.format_table().c_str());
  }
}

// Grey value of a debug-view pixel back to the LUT coordinate (linear).
double decode(const image::Image8& img, std::uint32_t x, std::uint32_t y) {
  return image::srgb_to_linear(img.at(x, y, 0) / 255.0f);
}

void curvature_table(Session& session, const Options& o) {
  std::printf("\n### Screen-space against per-vertex curvature\n\n");
  std::printf("The skin pass's debug view writes the LUT's curvature coordinate (1/r ÷ 1 mm⁻¹) per pixel, from the "
              "mesh's per-vertex |Δn|/|Δp| or from screen-space derivatives |fwidth(N)|/|fwidth(P)|. Spheres of radius "
              "r (mm) at %ux%u; pixels grouped by sphere; relative error against the exact 1/r.\n\n",
              o.width, o.height);
  auto renderer = renderer::Renderer::create(session.device);
  if (!renderer) return;
  auto vertex = load_text(sphere_row_scene(skin_json(1.0, R"(, "debug_view": "curvature")"), o.width, o.height, "[0, 0, 0]"));
  auto screen = load_text(sphere_row_scene(skin_json(1.0, R"(, "debug_view": "curvature", "curvature": "screen")"),
                                           o.width, o.height, "[0, 0, 0]"));
  if (!vertex || !screen) return;
  auto fv = renderer->render(*vertex, {.aces = false});
  auto fs = renderer->render(*screen, {.aces = false});
  if (!fv || !fs) return;
  (void)image::save_png("skin_curvature_vertex.png", fv->image);
  (void)image::save_png("skin_curvature_screen.png", fs->image);
  std::printf("| r (mm) | exact 1/r | pixels | vertex: median rel. error | screen: median rel. error | screen: 90th pct | screen: within 10%% |\n|---:|---:|---:|---:|---:|---:|---:|\n");
  for (double r : kSphereRadii) {
    const double exact = 1.0 / r;
    std::vector<double> ev, es;
    for (std::uint32_t y = 0; y < fv->image.height; ++y)
      for (std::uint32_t x = 0; x < fv->image.width; ++x) {
        const double v = decode(fv->image, x, y);
        if (v <= 0.0 || std::abs(v - exact) > 0.25 * exact) continue;  // another sphere, or the sky
        ev.push_back(std::abs(v - exact) / exact);
        es.push_back(std::abs(decode(fs->image, x, y) - exact) / exact);
      }
    if (es.empty()) continue;
    auto sorted = es;
    std::sort(sorted.begin(), sorted.end());
    const double within = double(std::count_if(es.begin(), es.end(), [](double e) { return e < 0.1; })) / es.size();
    std::printf("| %.1f | %.3f | %zu | %.3f | %.3f | %.3f | %.0f%% |\n", r, exact, es.size(), median(ev), sorted[sorted.size() / 2],
                sorted[sorted.size() * 9 / 10], 100.0 * within);
  }
  if (const auto head = find_head(o)) {
    auto hv = load_text(head_scene(*head, skin_json(kHeadMmPerUnit, R"(, "debug_view": "curvature")"), o.width, o.height,
                                   "[0, 0, 0]"));
    auto hs = load_text(head_scene(*head, skin_json(kHeadMmPerUnit, R"(, "debug_view": "curvature", "curvature": "screen")"),
                                   o.width, o.height, "[0, 0, 0]"));
    if (!hv || !hs) return;
    auto a = renderer->render(*hv, {.aces = false});
    auto b = renderer->render(*hs, {.aces = false});
    if (!a || !b) return;
    (void)image::save_png("skin_head_curvature_vertex.png", a->image);
    (void)image::save_png("skin_head_curvature_screen.png", b->image);
    // Head pixels: where either view is non-zero (the sky is black).
    std::vector<double> diff, rel;
    double sv = 0, ss = 0, svv = 0, sss = 0, svs = 0;
    for (std::uint32_t y = 0; y < a->image.height; ++y)
      for (std::uint32_t x = 0; x < a->image.width; ++x) {
        const double v = decode(a->image, x, y), s = decode(b->image, x, y);
        if (v <= 0.0 && s <= 0.0) continue;
        diff.push_back(std::abs(s - v));
        if (v > 0.005) rel.push_back(std::abs(s - v) / v);
        sv += v;
        ss += s;
        svv += v * v;
        sss += s * s;
        svs += v * s;
      }
    if (diff.empty()) return;
    const double n = double(diff.size());
    const double corr = (svs / n - sv / n * ss / n) /
                        std::sqrt(std::max(1e-30, (svv / n - sv * sv / (n * n)) * (sss / n - ss * ss / (n * n))));
    std::sort(diff.begin(), diff.end());
    std::sort(rel.begin(), rel.end());
    std::printf("\nHead scan at %.0f mm per unit, %zu head pixels: mean 1/r per vertex %.4f, screen-space %.4f per mm; "
                "|screen − vertex| median %.4f, 90th percentile %.4f per mm; relative: median %.2f, 90th percentile %.2f; "
                "correlation %.2f (images: skin_head_curvature_{vertex,screen}.png).\n",
                kHeadMmPerUnit, diff.size(), sv / n, ss / n, diff[diff.size() / 2], diff[diff.size() * 9 / 10],
                rel.empty() ? 0.0 : rel[rel.size() / 2], rel.empty() ? 0.0 : rel[rel.size() * 9 / 10], corr);
  }
}

// Image-space error of LUT renders against the reference mode (brute-force scattering per
// vertex through the same pass), on the sphere row.
void image_table(Session& session, const Options& o) {
  std::printf("\n### Rendered images against the reference mode\n\n");
  std::printf("The sphere row (r = 1.5, 3, 6, 12 mm, 128 segments) at %ux%u, black sky, no specular or "
              "transmittance; the reference render shades each vertex with mesh_reference for the key light "
              "(\"reference\": true). RMSE and largest difference of linear RGB over the spheres' pixels.\n\n",
              o.width, o.height);
  auto renderer = renderer::Renderer::create(session.device);
  if (!renderer) return;
  const char* common = R"(, "specular": 0, "transmittance": false)";
  auto reference_scene = load_text(
      sphere_row_scene(skin_json(1.0, weft::format("{}, \"reference\": true", common).c_str()), o.width, o.height, "[0, 0, 0]"));
  if (!reference_scene) return;
  const auto t0 = Clock::now();
  auto reference = renderer->render(*reference_scene, {.aces = false});
  if (!reference) {
    std::printf("render error: %s\n", reference.error().message.c_str());
    return;
  }
  const double reference_s = ms_since(t0) / 1000.0;
  const image::Image ref = image::from_srgb8(reference->image);
  (void)image::save_png("skin_image_reference.png", reference->image);
  std::printf("| LUT | range | RMSE | max | frame GPU ms |\n|---|---|---:|---:|---:|\n");
  auto row = [&](const char* label, std::uint32_t size, const char* range) {
    auto s = load_text(sphere_row_scene(
        skin_json(1.0, weft::format("{}, \"lut\": {{\"size\": {}, \"range\": \"{}\"}}", common, size, range).c_str()),
        o.width, o.height, "[0, 0, 0]"));
    if (!s) return;
    auto f = renderer->render(*s, {.aces = false});
    if (!f) return;
    const image::Image img = image::from_srgb8(f->image);
    double se = 0.0, worst = 0.0;
    std::size_t n = 0, worst_at = 0;
    for (std::size_t i = 0; i < img.pixels.size(); i += img.channels) {
      if (ref.pixels[i] + ref.pixels[i + 1] + ref.pixels[i + 2] <= 0.0f && img.pixels[i] <= 0.0f) continue;
      for (int c = 0; c < 3; ++c) {
        const double e = double(img.pixels[i + c]) - ref.pixels[i + c];
        se += e * e;
        if (std::abs(e) > worst) {
          worst = std::abs(e);
          worst_at = i / img.channels;
        }
        ++n;
      }
    }
    std::printf("| %s | %s | %.4f | %.3f at (%zu, %zu) | %.2f |\n", label, range, std::sqrt(se / std::max<std::size_t>(n, 1)),
                worst, worst_at % img.width, worst_at / img.width, f->stats.gpu_total_ms);
    if (size == 256 && std::string_view(range) == "adaptive") (void)image::save_png("skin_image_lut.png", f->image);
  };
  for (const char* range : {"penner", "adaptive", "full"}) row("256²", 256, range);
  for (std::uint32_t size : {16u, 64u}) row(size == 16 ? "16²" : "64²", size, "adaptive");
  std::printf("\n(Reference frame: %.1f s, almost all of it the CPU gather.) 8-bit sRGB readback quantises by up to "
              "about 0.002 in linear terms near white.\n",
              reference_s);
}

}  // namespace

int main(int argc, char** argv) {
  // This program links one feature and registers it, as any application does.
  // The frame's pass types (the default pipeline's shadow map, scene colour, background, tone map).
  if (auto ok = weft::register_builtin_pass_types(); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  if (auto ok = register_feature(passes::skin_sss_feature()); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    // Digits only, sizes 1..8192, sections by name (issue 33: atoi read "abc" as 1 run, sscanf
    // "-1x-1" as 4294967295 pixels, and an unknown section ran nothing).
    const auto bad = [&](const std::string& why) {
      std::fprintf(stderr, "weft-bench-skin: %s (see --help)\n", why.c_str());
      return 2;
    };
    static const std::set<std::string> sections = {"conventions", "range", "size", "samples", "time",
                                                   "mesh", "frame", "curvature", "image"};
    if (a == "--runs" || a == "--head" || a == "--size") {
      if (i + 1 >= argc) return bad(a + " needs a value");
      const std::string v = argv[++i];
      if (v.empty()) return bad(a + " was given an empty value");
      if (a == "--head") {
        o.head = v;
      } else if (a == "--runs") {
        const auto n = weft::args::whole(v, 1, 10000);
        if (!n) return bad("--runs '" + v + "': expected a whole number 1..10000");
        o.runs = int(*n);
      } else {
        const auto size = weft::args::size(v, 8192);
        if (!size) return bad("--size '" + v + "': expected WxH with sides 1..8192");
        std::tie(o.width, o.height) = *size;
      }
    } else if (a == "-h" || a == "--help") {
      std::printf("weft-bench-skin [conventions range size samples time mesh frame curvature image] [--runs N] [--head PATH] [--size WxH]\n");
      return 0;
    } else if (a.starts_with("-")) {
      return bad("unknown option " + a);
    } else if (sections.contains(a)) {
      o.sections.insert(a);
    } else {
      return bad("unknown section '" + a + "'");
    }
  }
  // A --head that is not a mesh is named before the tables (issue 33: it surfaced as a table row
  // after minutes of other sections, and a FIFO would have waited).
  if (!o.head.empty())
    if (auto head = scene::load_mesh(o.head); !head) {
      std::fprintf(stderr, "weft-bench-skin: --head: %s\n", head.error().what().c_str());
      return 1;
    }
  std::printf("# weft-bench-skin\n\nCPU: %u hardware threads.\n", std::thread::hardware_concurrency());
  if (o.wants("conventions")) conventions_table();
  if (o.wants("range")) range_table();
  if (o.wants("size")) size_table();
  if (o.wants("samples")) samples_table();
  if (o.wants("time")) time_table(o.runs);
  if (o.wants("mesh")) mesh_table(o);
  if (o.wants("frame") || o.wants("curvature") || o.wants("image")) {
    auto session = bench::open_session("weft-bench-skin");
    if (!session) {
      std::printf("\n(no Vulkan device: frame and curvature sections skipped)\n");
      return 0;
    }
    if (o.wants("frame")) frame_table(*session, o);
    if (o.wants("curvature")) curvature_table(*session, o);
    if (o.wants("image")) image_table(*session, o);
  }
  return 0;
}
