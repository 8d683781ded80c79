// weft-bench-ssdf: the SSDF paper's table on a teapot + floor (docs/ssdf.md): raw and
// compressed sizes, ratio, SSDF RMSE (radians), visibility sign error rate and bake times
// (visibility, distance transform, CPCA) for the paper's two settings (64 clusters with
// m = 48; 90 % energy per cluster), variants (mean-centering, fp16/8-bit coefficients,
// seedings) and a sweep of k and m; plus the fast distance transform against the exact one.
//   weft-bench-ssdf [--resolution N] [--threads T] [--teapot PATH] [--quick] [--only TEXT]
// (--only: just the compression rows whose name contains TEXT)
//   weft-bench-ssdf --lighting [--size PIXELS] [--samples N] [--runs R] [--quick]
// (SSDFLightingPass on lavapipe: the teapot resampled to 12,801 vertices + floor under the
// shipped HDR: rendered-image RMSE against the Embree Monte-Carlo reference for the paper's
// settings, k/m, lobes, shading modes and resolutions, and the pass's GPU time per frame.)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <weft/args.h>
import weft.core;
import weft.feature;
import weft.cluster;
import weft.image;
import weft.gpu;
import weft.scene;
import weft.ssdf;
import weft.renderer;
import weft.builtin_features;
import weft.pass.ssdf_lighting;
import weft.example.fur_resample;

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

int lighting_bench(int argc, char** argv);

int main(int argc, char** argv) {
  // This program links one feature and registers it, as any application does.
  // The frame's pass types (the default pipeline's shadow map, scene colour, background, tone map).
  if (auto ok = weft::register_builtin_pass_types(); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  if (auto ok = register_feature(passes::ssdf_lighting_feature()); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--lighting") return lighting_bench(argc, argv);
  std::uint32_t resolution = 64;
  std::size_t threads = 0;
  bool quick = false;
  std::string only;
  const char* shared = std::getenv("WEFT_SHARED_DATA");
  std::filesystem::path teapot = std::filesystem::path(shared ? shared : WEFT_DEFAULT_SHARED_DATA) / "meshes/teapot/teapot.obj";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    // Digits only, within a range (issue 33: atoi read "-1" as 4294967295 directions).
    if ((arg == "--resolution" || arg == "--threads") && i + 1 < argc) {
      const auto n = weft::args::whole(argv[++i], arg == "--threads" ? 0 : 1, 1024);
      if (!n) {
        std::fprintf(stderr, "weft-bench-ssdf: %s expects a whole number %s..1024, got '%s'\n", arg.c_str(),
                     arg == "--threads" ? "0" : "1", argv[i]);
        return 2;
      }
      if (arg == "--threads") threads = std::size_t(*n);
      else resolution = std::uint32_t(*n);
    } else if (arg == "--teapot" && i + 1 < argc) teapot = argv[++i];
    else if (arg == "-h" || arg == "--help") {
      std::printf("usage: weft-bench-ssdf [--resolution N] [--threads T] [--teapot PATH] [--quick] [--only TEXT]\n"
                  "       weft-bench-ssdf --lighting [--size PIXELS] [--samples N] [--runs R] [--teapot PATH] [--quick]\n");
      return 0;
    } else if (arg == "--quick") quick = true, resolution = 16;
    else if ((arg == "--only" || arg == "--teapot") && i + 1 < argc && argv[i + 1][0] == '\0') {
      std::fprintf(stderr, "weft-bench-ssdf: %s was given an empty value\n", arg.c_str());
      return 2;
    } else if (arg == "--only" && i + 1 < argc) only = argv[++i];
    else {
      std::fprintf(stderr, "weft-bench-ssdf: unknown or incomplete argument '%s'\n", argv[i]);
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

// ---- --lighting: SSDFLightingPass against the Monte-Carlo reference ----------------------

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct LightingRow {
  std::string name;
  nlohmann::json material;  // the "ssdf" material's params
  bool singular_value_rule = false;  // rebuilt by singular_value_cpca (see there)
};

struct Compression {
  std::size_t bytes = 0;
  double ratio = 0.0, rmse = 0.0, sign = 0.0, components = 0.0;
};

// The paper's "90 %" read as cumulative singular values (not their squares): each cluster of
// `clustered` (its rows, uncentred) keeps the fewest components whose singular values sum to
// `fraction` of all of them. weft.cluster's energy rule uses squared singular values, so this
// row is assembled here from the same clusters.
Result<cluster::Cpca> singular_value_cpca(const cluster::Matrix& raw, const cluster::Cpca& clustered, double fraction) {
  cluster::Cpca out;
  out.cols = raw.cols;
  out.row_count = raw.rows;
  out.cluster_of = clustered.cluster_of;
  out.slot_of = clustered.slot_of;
  for (const auto& c : clustered.clusters) {
    cluster::CpcaCluster cc;
    cc.rows = c.rows;
    if (c.rows.empty()) {
      out.clusters.push_back(std::move(cc));
      continue;
    }
    cluster::Matrix data(c.rows.size(), raw.cols);
    for (std::size_t r = 0; r < c.rows.size(); ++r) std::copy_n(raw.row(c.rows[r]).data(), raw.cols, data.row(r).data());
    auto pca = cluster::fit_pca(data, {.center = false});
    if (!pca) return std::unexpected(pca.error());
    double total = 0.0, sum = 0.0;
    for (double e : pca->energy) total += std::sqrt(std::max(e, 0.0));
    std::size_t m = 0;
    while (m < pca->energy.size() && m < pca->components() && sum < fraction * total) sum += std::sqrt(std::max(pca->energy[m++], 0.0));
    pca->basis.rows = m;
    pca->basis.values.resize(m * raw.cols);
    cc.basis = pca->basis;
    cc.coefficients = cluster::project(*pca, data);
    out.clusters.push_back(std::move(cc));
  }
  return out;
}

// Linear green of the renderer's 8-bit sRGB output against the reference (clamped to the
// 8-bit range), over pixels whose 3x3 neighbourhood shows one object in the reference.
double relative_rmse(const image::Image8& img, const ssdf::ReferenceImage& ref, float scale) {
  double err = 0.0, sum = 0.0;
  std::size_t n = 0;
  for (std::uint32_t y = 1; y + 1 < ref.height; ++y)
    for (std::uint32_t x = 1; x + 1 < ref.width; ++x) {
      const std::uint32_t object = ref.object[y * ref.width + x];
      bool interior = object != ~0u;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) interior = interior && ref.object[(y + dy) * ref.width + (x + dx)] == object;
      if (!interior) continue;
      const double truth = std::min(ref.radiance[y * ref.width + x].y * scale, 1.0f);
      const double got = image::srgb_to_linear(img.at(x, y, 1) / 255.0f);
      err += (got - truth) * (got - truth);
      sum += truth;
      ++n;
    }
  return n ? std::sqrt(err / double(n)) / (sum / double(n)) : -1.0;
}

double relative_rmse(const ssdf::ReferenceImage& a, const ssdf::ReferenceImage& b) {
  double err = 0.0, sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.radiance.size(); ++i)
    if (a.mask[i]) {
      err += std::pow(double(a.radiance[i].y) - b.radiance[i].y, 2.0);
      sum += b.radiance[i].y;
      ++n;
    }
  return n ? std::sqrt(err / double(n)) / (sum / double(n)) : -1.0;
}

}  // namespace

int lighting_bench(int argc, char** argv) {
  std::uint32_t size = 192, samples = 1024, runs = 7;
  bool quick = false;
  const char* shared = std::getenv("WEFT_SHARED_DATA");
  std::filesystem::path teapot = std::filesystem::path(shared ? shared : WEFT_DEFAULT_SHARED_DATA) / "meshes/teapot/teapot.obj";
  std::filesystem::path hdr = std::filesystem::path(WEFT_SOURCE_DIR) / "assets/env/royal_esplanade_1k.hdr";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--lighting") continue;
    if ((arg == "--size" || arg == "--samples" || arg == "--runs") && i + 1 < argc) {
      const std::uint64_t hi = arg == "--size" ? 8192 : arg == "--samples" ? 1'000'000 : 1000;
      const auto n = weft::args::whole(argv[++i], 1, hi);
      if (!n) {
        std::fprintf(stderr, "weft-bench-ssdf --lighting: %s expects a whole number 1..%llu, got '%s'\n", arg.c_str(),
                     static_cast<unsigned long long>(hi), argv[i]);
        return 2;
      }
      (arg == "--size" ? size : arg == "--samples" ? samples : runs) = std::uint32_t(*n);
    } else if (arg == "--teapot" && i + 1 < argc) teapot = argv[++i];
    else if (arg == "--quick") quick = true;
    else {
      std::fprintf(stderr, "weft-bench-ssdf --lighting: unknown or incomplete argument '%s'\n", argv[i]);
      std::fprintf(stderr, "usage: weft-bench-ssdf --lighting [--size PIXELS] [--samples N] [--runs R] [--teapot PATH] [--quick]\n");
      return 2;
    }
  }
  log::set_level(std::getenv("WEFT_LOG") ? std::getenv("WEFT_LOG") : "warn");
  // The renderer's bake cache is where this benchmark puts its bakes: one visibility bake and
  // distance transform per resolution, compressed per row, written under the key the
  // feature computes, so the renderer loads them instead of baking again.
  const std::filesystem::path cache = std::filesystem::temp_directory_path() / "weft-bench-ssdf-cache";
  std::filesystem::create_directories(cache);
  setenv("WEFT_SSDF_CACHE", cache.c_str(), 1);

  auto pot = scene::load_mesh(teapot, {.normalize_to_unit_box = true});
  if (!pot) {
    std::fprintf(stderr, "weft-bench-ssdf: %s\n", pot.error().what().c_str());
    return 1;
  }
  auto resampled = examples::resample(*pot, quick ? 2000 : 12801);
  if (!resampled) {
    std::fprintf(stderr, "weft-bench-ssdf: resampling: %s\n", resampled.error().what().c_str());
    return 1;
  }
  auto env = scene::load_environment(hdr);
  if (!env) {
    std::fprintf(stderr, "weft-bench-ssdf: %s\n", env.error().what().c_str());
    return 1;
  }
  scene::Scene s;
  const float lift = -resampled->bounds.min.y;
  s.meshes.push_back(std::move(*resampled));
  s.meshes.push_back(*scene::make_plane(3.0f, quick ? 16 : 64));
  s.objects.push_back({.name = "teapot", .mesh = 0, .material = 0,
                       .transform = scene::Transform{.translation = {0.0f, lift, 0.0f}}.matrix()});
  s.objects.push_back({.name = "floor", .mesh = 1, .material = 0, .transform = mat4(1.0f)});
  s.materials.push_back({.name = "ssdf", .type = passes::ssdf_lighting_feature().name});
  s.materials[0].json_path = "$.materials.ssdf";
  s.camera = {.position = {1.5f, 1.25f, 2.0f}, .target = {0.0f, 0.3f, 0.0f}, .fov_y_degrees = 38.0f, .near = 0.3f, .far = 20.0f};
  s.environment = std::move(*env);
  s.output = {.width = size, .height = size};
  const std::vector<std::uint32_t> objects = {0, 1};
  std::printf("# weft-bench-ssdf --lighting\n\nscene: teapot resampled to %zu v + floor %zu v; environment %s; %u x %u "
              "pixels; reference %u rays a pixel\n\n",
              s.meshes[0].vertex_count(), s.meshes[1].vertex_count(), hdr.filename().c_str(), size, size, samples);

  // The reference: environment only (no key light), Lambert albedo 0.8; scaled so that the
  // 99th percentile of the visible surfaces is 0.85 (the 8-bit output's range).
  const vec3 albedo(0.8f);
  const std::vector<vec3> albedos(2, albedo);
  auto camera = [&] {
    const mat4 vp = s.camera.projection(1.0f) * s.camera.view();
    return ssdf::ReferenceCamera{glm::inverse(vp), s.camera.position, size, size};
  }();
  auto radiance = [&](const vec3& d) { return s.environment.radiance(d); };
  auto t = std::chrono::steady_clock::now();
  auto reference = ssdf::reference_image(s, camera, albedos, radiance, std::nullopt, {.samples = samples, .seed = 1});
  const double reference_s = seconds_since(t);
  auto second = ssdf::reference_image(s, camera, albedos, radiance, std::nullopt, {.samples = samples, .seed = 2, .progress = false});
  if (!reference || !second) {
    std::fprintf(stderr, "weft-bench-ssdf: reference failed\n");
    return 1;
  }
  std::vector<double> greens;
  for (std::size_t i = 0; i < reference->radiance.size(); ++i)
    if (reference->mask[i]) greens.push_back(reference->radiance[i].y);
  std::sort(greens.begin(), greens.end());
  const float scale = 0.85f / float(greens[greens.size() * 99 / 100]);
  s.environment.intensity *= scale;
  const double noise = relative_rmse(*reference, *second) / std::sqrt(2.0);
  std::printf("Reference: %.1f s; its own Monte-Carlo noise (two seeds, relative RMSE / √2): %.4f; environment "
              "intensity scaled by %.3f.\n\n", reference_s, noise, scale);
  {
    image::Image8 out = image::Image8::filled(size, size, 4);
    for (std::size_t i = 0; i < reference->radiance.size(); ++i) {
      const vec3 c = reference->radiance[i] * scale;
      for (int k = 0; k < 3; ++k) out.pixels[i * 4 + std::size_t(k)] = std::uint8_t(std::lround(255.0f * image::linear_to_srgb(std::clamp(c[k], 0.0f, 1.0f))));
      out.pixels[i * 4 + 3] = 255;
    }
    (void)image::save_png(cache / "reference.png", out);
  }

  // Bakes per resolution (visibility + distance transform once each), with the material's
  // visibility options: the renderer loads these bakes under its own cache key, so they must
  // be the bakes it would make (below-horizon directions visible, as the material sets).
  struct Raw {
    ssdf::BakeMesh probes;
    cluster::Matrix ssdf;
  };
  std::map<std::uint64_t, Raw> raws;  // by the visibility part of the bake key
  auto raw_for = [&](ssdf::BakeOptions options) -> const Raw* {
    options.compression = {};  // tried below in many settings: not part of this bake
    options.visibility.progress = false;
    const std::uint64_t key = ssdf::bake_key(s, objects, options);
    if (auto it = raws.find(key); it != raws.end()) return &it->second;
    // The lighting feature's own bake, without its compression.
    auto baked = ssdf::bake_object_distances(s, objects, options);
    if (!baked) return nullptr;
    std::printf("(bake %ux%u: visibility %.1f s, distance transform %.1f s)\n\n", options.resolution,
                options.resolution, baked->timings.visibility_s, baked->timings.distance_s);
    return &raws.emplace(key, Raw{std::move(baked->probes), std::move(baked->raw)}).first->second;
  };

  auto device_instance = gpu::Instance::create({.application_name = "weft-bench-ssdf"});
  if (!device_instance) return 1;
  auto adapter = device_instance->request_adapter();
  if (!adapter) return 1;
  auto device = adapter->request_device({.label = "bench"});
  if (!device) return 1;
  std::printf("Device: %s (%s); GPU times from timestamps, median of %u frames after one warm-up.\n\n",
              adapter->info().name.c_str(), adapter->info().driver.c_str(), runs);

  // The forward pass drawing the same geometry with a standard material: the baseline.
  double forward_ms = -1.0;
  {
    scene::Scene plain = s;
    plain.materials[0] = {.name = "plain", .type = std::string(scene::standard_material)};
    auto r = renderer::Renderer::create(*device);
    std::vector<double> ms;
    for (std::uint32_t i = 0; i <= runs; ++i) {
      auto f = r->render(plain, {.aces = false});
      if (!f) return 1;
      for (const auto& p : f->stats.passes)
        if (p.name == "forward" && i > 0) ms.push_back(p.gpu_ms);
    }
    forward_ms = median(ms);
  }

  using nlohmann::json;
  auto mat = [](std::uint32_t res, std::uint32_t lobes, const char* shading, json bake) {
    bake["resolution"] = res;
    return json{{"albedo", {0.8, 0.8, 0.8}}, {"shading", shading}, {"lobes", lobes}, {"bake", bake}};
  };
  const std::uint32_t full = quick ? 16 : 64;
  const json def = {{"clusters", 32}, {"components", 16}};
  std::vector<LightingRow> rows = {
      {"paper 1: k 64, m 48, farthest, no centring", mat(full, 32, "pixel", {{"clusters", 64}, {"components", 48}, {"seeding", "farthest"}, {"center", false}})},
      {"paper 2: k 64, 90 % energy, farthest, no centring", mat(full, 32, "pixel", {{"clusters", 64}, {"components", 65536}, {"energy", 0.9}, {"seeding", "farthest"}, {"center", false}})},
      // Farthest-point clusters as paper 1 (seed 7, which also keys this benchmark-made file).
      {"paper 2 as cumulative singular values: k 64, 90 %, farthest, no centring", mat(full, 32, "pixel", {{"clusters", 64}, {"components", 65536}, {"energy", 0.9}, {"seeding", "farthest"}, {"center", false}, {"seed", 7}}), true},
      {"k 64, m 48, k-means++", mat(full, 32, "pixel", {{"clusters", 64}, {"components", 48}})},
      {"k 64, m 8, k-means++", mat(full, 32, "pixel", {{"clusters", 64}, {"components", 8}})},
      {"k 16, m 16, k-means++, fp16 basis + coefficients", mat(full, 32, "pixel", {{"clusters", 16}, {"components", 16}, {"coefficients", "fp16"}, {"half_basis", true}})},
      {"k 32, m 4 (default k)", mat(full, 32, "pixel", {{"clusters", 32}, {"components", 4}})},
      {"k 32, m 16 (default), 32 lobes", mat(full, 32, "pixel", def)},
  };
  for (std::uint32_t lobes : {4u, 8u, 16u, 48u}) rows.push_back({weft::format("default, {} lobes", lobes), mat(full, lobes, "pixel", def)});
  rows.push_back({"default, 32 lobes, vertex shading", mat(full, 32, "vertex", def)});
  rows.push_back({"default, 16 lobes, vertex shading", mat(full, 16, "vertex", def)});
  if (!quick)
    for (std::uint32_t res : {16u, 32u}) rows.push_back({weft::format("default, 32 lobes, {}x{} directions", res, res), mat(res, 32, "pixel", def)});

  std::map<std::string, Compression> compressed;  // by cache file
  std::printf("| setting | directions | lobes | shading | components (mean/cluster) | compressed | smaller by | SSDF RMSE (rad) | sign errors | image RMSE (relative) | ssdf_lighting GPU ms | / forward pass |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& row : rows) {
    s.materials[0].params = row.material;
    auto parsed = ssdf::parse_ssdf_material(s.materials[0], Quality::Medium);
    if (!parsed) {
      std::fprintf(stderr, "%s: %s\n", row.name.c_str(), parsed.error().what().c_str());
      return 1;
    }
    const Raw* raw = raw_for(parsed->bake);
    if (!raw) return 1;
    const auto file = cache / ("ssdf-" + hex64(ssdf::bake_key(s, objects, parsed->bake)) + ".wssdf");
    auto known = compressed.find(file.string());
    if (known == compressed.end()) {
      auto c = ssdf::compress(raw->probes, raw->ssdf, parsed->bake.compression);
      if (!c) return 1;
      if (row.singular_value_rule) {
        auto rebuilt = singular_value_cpca(raw->ssdf, c->cpca, 0.9);
        if (!rebuilt) return 1;
        c->cpca = std::move(*rebuilt);
      }
      const auto e = ssdf::measure_error(raw->ssdf, c->cpca);
      const std::size_t bytes = c->cpca.compressed_bytes();
      known = compressed.emplace(file.string(), Compression{bytes, 1.0 - double(bytes) / double(raw->ssdf.values.size() * sizeof(float)),
                                                             e.rmse, e.sign_error_rate,
                                                             double(c->cpca.total_components()) / double(c->cpca.clusters.size())}).first;
      if (auto ok = ssdf::write_file(file, ssdf::make_asset(parsed->bake.resolution, parsed->bake.compression, std::move(c->cpca))); !ok)
        return 1;
    }
    const Compression& cm = known->second;
    const double ssdf_rmse = cm.rmse, sign = cm.sign, ratio = cm.ratio;
    const std::size_t bytes = cm.bytes;
    auto r = renderer::Renderer::create(*device);
    std::vector<double> ms;
    image::Image8 first;
    for (std::uint32_t i = 0; i <= runs; ++i) {
      auto f = r->render(s, {.aces = false});
      if (!f) {
        std::fprintf(stderr, "%s: %s\n", row.name.c_str(), f.error().what().c_str());
        return 1;
      }
      if (i == 0) first = f->image;
      for (const auto& p : f->stats.passes)
        if (p.name == "ssdf_lighting" && i > 0) ms.push_back(p.gpu_ms);
    }
    const double image_rmse = relative_rmse(first, *reference, scale);
    std::printf("| %s | %ux%u | %u | %s | %.1f | %s | %.2f %% | %.4f | %.3f %% | %.4f | %.2f | %.2fx |\n", row.name.c_str(),
                parsed->bake.resolution, parsed->bake.resolution, parsed->lobes, std::string(ssdf::to_string(parsed->shading)).c_str(),
                cm.components, megabytes(bytes).c_str(), 100.0 * ratio, ssdf_rmse, 100.0 * sign, image_rmse, median(ms), median(ms) / forward_ms);
    std::fflush(stdout);
    if (row.name.starts_with("k 32, m 16 (default)")) (void)image::save_png(cache / "ssdf.png", first);
  }
  std::printf("\nForward pass (standard material, same geometry): %.2f GPU ms. Images: %s/{reference,ssdf}.png\n", forward_ms,
              cache.c_str());
  return 0;
}
