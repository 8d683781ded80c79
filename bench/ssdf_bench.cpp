// weft-bench-ssdf: the SSDF paper's table on a teapot + floor (docs/ssdf.md): raw and
// compressed sizes, ratio, SSDF RMSE (radians), visibility sign error rate and bake times
// (visibility, distance transform, CPCA) for the paper's two settings (64 clusters with
// m = 48; 90 % energy per cluster), variants (mean-centering, fp16/8-bit coefficients,
// seedings) and a sweep of k and m; plus the fast distance transform against the exact one.
//   weft-bench-ssdf [--resolution N] [--threads T] [--teapot PATH] [--quick] [--only TEXT]
// (--only: just the compression rows whose name contains TEXT)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.cluster;
import weft.scene;
import weft.ssdf;

using namespace weft;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

std::string megabytes(std::size_t bytes) { return weft::format("{:.1f} MB", double(bytes) / (1024.0 * 1024.0)); }

struct Row {
  std::string name;
  ssdf::CompressOptions options;
};
}  // namespace

int main(int argc, char** argv) {
  std::uint32_t resolution = 64;
  std::size_t threads = 0;
  bool quick = false;
  std::string only;
  const char* shared = std::getenv("WEFT_SHARED_DATA");
  std::filesystem::path teapot = std::filesystem::path(shared ? shared : WEFT_DEFAULT_SHARED_DATA) / "meshes/teapot/teapot.obj";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--resolution" && i + 1 < argc) resolution = std::uint32_t(std::atoi(argv[++i]));
    else if (arg == "--threads" && i + 1 < argc) threads = std::size_t(std::atoi(argv[++i]));
    else if (arg == "--teapot" && i + 1 < argc) teapot = argv[++i];
    else if (arg == "--quick") quick = true, resolution = 16;
    else if (arg == "--only" && i + 1 < argc) only = argv[++i];
    else {
      std::fprintf(stderr, "usage: weft-bench-ssdf [--resolution N] [--threads T] [--teapot PATH] [--quick] [--only TEXT]\n");
      return 2;
    }
  }
  log::set_level(std::getenv("WEFT_LOG") ? std::getenv("WEFT_LOG") : "warn");

  // The scene: the teapot as it is (unit box, on the floor) and a 64 x 64-quad floor
  // (4,225 vertices, the paper's floor).
  auto pot = scene::load_mesh(teapot, {.normalize_to_unit_box = true});
  if (!pot) {
    std::fprintf(stderr, "weft-bench-ssdf: %s\n", pot.error().what().c_str());
    return 1;
  }
  scene::Scene s;
  const float lift = -pot->bounds.min.y;
  s.meshes.push_back(std::move(*pot));
  s.meshes.push_back(*scene::make_plane(3.0f, quick ? 16 : 64));
  s.objects.push_back({.name = "teapot", .mesh = 0, .material = 0,
                       .transform = scene::Transform{.translation = {0.0f, lift, 0.0f}}.matrix()});
  s.objects.push_back({.name = "floor", .mesh = 1, .material = 0, .transform = mat4(1.0f)});
  auto mesh = ssdf::merge_scene(s);
  if (!mesh) return 1;
  const ssdf::DirectionGrid grid(resolution);
  std::printf("# weft-bench-ssdf\n\nscene: teapot %zu v + floor %zu v = %zu vertices, %zu triangles; %u x %u = %zu "
              "directions; threads %zu (0 = all)\n\n",
              s.meshes[0].vertex_count(), s.meshes[1].vertex_count(), mesh->vertex_count(), mesh->triangle_count(),
              resolution, resolution, grid.size(), threads);

  auto t = std::chrono::steady_clock::now();
  auto visibility = ssdf::bake_visibility(*mesh, ssdf::vertex_probes(*mesh), grid, {.threads = threads, .progress = false});
  if (!visibility) {
    std::fprintf(stderr, "weft-bench-ssdf: %s\n", visibility.error().what().c_str());
    return 1;
  }
  const double visibility_s = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const auto raw = ssdf::signed_distances(grid, *visibility, threads, false, false);
  const double distance_s = seconds_since(t);
  std::size_t open = 0, enclosed = 0, teapot_open = 0;
  const std::size_t teapot_vertices = s.meshes[0].vertex_count();
  for (std::size_t p = 0; p < visibility->probe_count; ++p) {
    std::size_t seen = 0;
    for (auto v : visibility->of(p)) seen += v;
    open += seen;
    enclosed += seen == 0;
    if (p < teapot_vertices) teapot_open += seen;
  }
  const double rays = double(visibility->visible.size());
  std::printf("## Bake\n\n| stage | time | notes |\n|---|---|---|\n");
  std::printf("| visibility (Embree rtcOccluded1) | %.2f s | %.0f rays, %.2f Mrays/s, %.1f %% unoccluded |\n", visibility_s,
              rays, rays / visibility_s * 1e-6, 100.0 * double(open) / rays);
  std::printf("| (visibility) | | teapot vertices %.1f %% unoccluded; %zu vertices (%.1f %%) see nothing (presumably the shell's inside wall) |\n",
              100.0 * double(teapot_open) / double(teapot_vertices * grid.size()), enclosed,
              100.0 * double(enclosed) / double(visibility->probe_count));
  std::printf("| distance transform (ordered propagation) | %.2f s | %.1f µs per vertex |\n", distance_s,
              distance_s / double(mesh->vertex_count()) * 1e6);

  // The fast transform against the exact one on an evenly spaced subset of vertices.
  const std::size_t subset = quick ? 64 : 256;
  ssdf::Visibility some;
  some.directions = visibility->directions;
  for (std::size_t i = 0; i < subset; ++i) {
    const auto row = visibility->of(i * mesh->vertex_count() / subset);
    some.visible.insert(some.visible.end(), row.begin(), row.end());
  }
  some.probe_count = subset;
  t = std::chrono::steady_clock::now();
  const auto exact = ssdf::signed_distances(grid, some, threads, true, false);
  const double exact_s = seconds_since(t);
  const auto fast = ssdf::signed_distances(grid, some, threads, false, false);
  const auto dt_error = ssdf::measure_error(exact, fast);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < fast.values.size(); ++i) differ += std::abs(fast.values[i] - exact.values[i]) > 1e-5f;
  std::printf("| exact O(D²) transform, %zu vertices | %.2f s | %.1f ms per vertex (%.0fx the fast one) |\n\n", subset,
              exact_s, exact_s / double(subset) * 1e3, (exact_s / double(subset)) / (distance_s / double(mesh->vertex_count())));
  std::printf("Fast vs exact distance transform (%zu vertices): RMSE %.5f rad, max %.4f rad (grid spacing %.4f rad), "
              "%.2f %% of samples differ by more than 1e-5 rad, sign errors %.4f %%.\n\n",
              subset, dt_error.rmse, dt_error.max_abs, grid.spacing(), 100.0 * double(differ) / double(fast.values.size()),
              100.0 * dt_error.sign_error_rate);
  visibility->visible = {};

  const std::size_t raw_bytes = raw.values.size() * sizeof(float);
  const auto fp16 = cluster::CoefficientFormat::Float16,
             u8 = cluster::CoefficientFormat::Unorm8;
  const auto kpp = cluster::Seeding::KMeansPlusPlus, fps = cluster::Seeding::FarthestPoint;
  const std::size_t all = 1u << 30;
  std::vector<Row> rows = {
      {"paper 1: k 64, m 48, no centring", {.clusters = 64, .seeding = fps, .max_components = 48, .center = false}},
      {"paper 2: k 64, 90 % energy, no centring", {.clusters = 64, .seeding = fps, .max_components = all, .energy_fraction = 0.9, .center = false}},
      {"k 64, m 48, centred", {.clusters = 64, .seeding = fps, .max_components = 48}},
      {"k 64, 90 % energy, centred", {.clusters = 64, .seeding = fps, .max_components = all, .energy_fraction = 0.9}},
      {"k 64, m 48, k-means++ seeding", {.clusters = 64, .seeding = kpp, .max_components = 48}},
      {"k 64, m 48, centred, fp16", {.clusters = 64, .seeding = fps, .max_components = 48, .coefficients = fp16}},
      {"k 64, m 48, centred, 8-bit", {.clusters = 64, .seeding = fps, .max_components = 48, .coefficients = u8}},
      {"k 64, m 16, centred, fp16", {.clusters = 64, .seeding = fps, .max_components = 16, .coefficients = fp16}},
      {"k 64, 99 % energy, centred, fp16", {.clusters = 64, .seeding = fps, .max_components = all, .energy_fraction = 0.99, .coefficients = fp16}},
  };
  rows.push_back({"k 64, m 48, k-means++, fp16 basis + coefficients",
                  {.clusters = 64, .seeding = kpp, .max_components = 48, .coefficients = fp16, .half_basis = true}});
  for (std::size_t k : {16u, 32u})
    for (std::size_t m : {16u, 32u})
      rows.push_back({weft::format("k {}, m {}, k-means++, fp16 basis + coefficients", k, m),
                      {.clusters = k, .seeding = kpp, .max_components = m, .coefficients = fp16, .half_basis = true}});
  for (std::size_t k : {16u, 64u, 256u})
    for (std::size_t m : {4u, 8u, 16u, 32u})
      rows.push_back({weft::format("sweep: k {}, m {}, centred", k, m), {.clusters = k, .seeding = fps, .max_components = m}});
  if (quick) rows.resize(4);

  std::printf("## Compression (raw: %s = %zu vertices x %zu directions x fp32)\n\n", megabytes(raw_bytes).c_str(),
              raw.rows, raw.cols);
  std::printf("| setting | components (mean/cluster) | compressed | smaller by | RMSE (rad) | max error (rad) | sign errors | CPCA time |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (auto& row : rows) {
    if (!only.empty() && row.name.find(only) == std::string::npos) continue;
    row.options.threads = threads;
    t = std::chrono::steady_clock::now();
    auto c = ssdf::compress(*mesh, raw, row.options);
    const double cpca_s = seconds_since(t);
    if (!c) {
      std::fprintf(stderr, "%s: %s\n", row.name.c_str(), c.error().what().c_str());
      return 1;
    }
    const auto e = ssdf::measure_error(raw, c->cpca, threads);
    const std::size_t bytes = c->cpca.compressed_bytes();
    std::printf("| %s | %.1f | %s | %.2f %% | %.4f | %.3f | %.3f %% | %.2f s |\n", row.name.c_str(),
                double(c->cpca.total_components()) / double(c->cpca.clusters.size()), megabytes(bytes).c_str(),
                100.0 * (1.0 - double(bytes) / double(raw_bytes)), e.rmse, e.max_abs, 100.0 * e.sign_error_rate, cpca_s);
    std::fflush(stdout);
  }
  return 0;
}
