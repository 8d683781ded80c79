// `weft bake <asset> ...`: offline precomputes written to files. Each asset is a
// sub-subcommand made by one function below and listed in add_bake (one line each):
//   weft bake skin-lut -o lut.exr|png [--size N] [--range penner|adaptive|full] ...
//   weft bake ssdf SCENE -o out.wssdf [--resolution n] [--clusters k] [--components m | --energy f] ...
//   weft bake btf IN|--synthetic WxH -o out.wbtf [--clusters k] [--epochs n | --minutes m] ... (bake_btf.cpp)
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include "commands.h"
import weft.core;
import weft.pass.skin_sss;
import weft.cluster;
import weft.scene;
import weft.ssdf;

namespace weft::cli {

namespace {

using BakeTarget = std::pair<CLI::App*, Command>;

int bake_failed(const char* what, const Error& e) {
  std::fprintf(stderr, "weft bake %s: %s\n", what, e.what().c_str());
  return 1;
}

// The pre-integrated skin LUT (docs/skin.md): RGB diffuse D(N·L, 1/r), A Beckmann.
BakeTarget add_skin_lut(CLI::App& bake) {
  struct Args {
    std::string output;
    std::uint32_t size = 256, width = 0, height = 0, samples = 256, threads = 0;
    std::string range = "adaptive", convention = "default", normalization, quadrature = "per-gaussian";
    double variance_scale = 0.0, max_curvature = 1.0;
    bool alpha = false;
  };
  auto a = std::make_shared<Args>();
  auto* sub = bake.add_subcommand("skin-lut", "The pre-integrated skin LUT: RGB diffuse over (N·L, 1/r), alpha Beckmann");
  sub->add_option("-o,--output", a->output, "Output: .exr (linear RGBA float, the data) or .png (sRGB picture)")->required();
  sub->add_option("--size", a->size, "Texels per side (2..4096)")->capture_default_str();
  sub->add_option("--width", a->width, "N·L texels (default: --size)");
  sub->add_option("--height", a->height, "Curvature texels (default: --size)");
  sub->add_option("--range", a->range, "Integration range: penner (±π/2), adaptive (±π(r+1)/2r, the thesis), full (±π)")
      ->capture_default_str();
  sub->add_option("--convention", a->convention,
                  "Profile normalisation preset: default (ring, v×1.414), thesis (planar, v×1), penner (ring, v×1.414)")
      ->capture_default_str();
  sub->add_option("--normalization", a->normalization, "Override: ring (1/√(2πv)) or planar (1/(2πv))");
  sub->add_option("--variance-scale", a->variance_scale, "Override: multiply every variance by this");
  sub->add_option("--max-curvature", a->max_curvature, "1/r of the last row, in 1/mm (0, 10]")->capture_default_str();
  sub->add_option("--samples", a->samples, "Ring quadrature samples (per Gaussian)")->capture_default_str();
  sub->add_option("--quadrature", a->quadrature, "per-gaussian or uniform")->capture_default_str();
  sub->add_option("--threads", a->threads, "Threads (0: all)")->capture_default_str();
  sub->add_flag("--alpha", a->alpha, "PNG: keep the Beckmann alpha channel (EXR always has it)");
  return {sub, [a] {
            skin::LutParams p;
            p.width = a->width ? a->width : a->size;
            p.height = a->height ? a->height : a->size;
            auto range = skin::integration_range_from_string(a->range);
            if (!range) return bake_failed("skin-lut", range.error());
            p.range = *range;
            if (a->convention == "thesis") p.convention = skin::thesis_convention;
            else if (a->convention == "penner") p.convention = skin::penner_convention;
            else if (a->convention != "default")
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --convention '{}' (default, thesis, penner)", a->convention)});
            if (a->normalization == "ring") p.convention.normalization = skin::Normalization::Ring;
            else if (a->normalization == "planar") p.convention.normalization = skin::Normalization::Planar;
            else if (!a->normalization.empty())
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --normalization '{}' (ring, planar)", a->normalization)});
            if (a->variance_scale != 0.0) p.convention.variance_scale = a->variance_scale;
            if (a->quadrature == "uniform") p.quadrature = skin::Quadrature::Uniform;
            else if (a->quadrature != "per-gaussian")
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --quadrature '{}' (per-gaussian, uniform)", a->quadrature)});
            p.max_curvature = a->max_curvature;
            p.samples = a->samples;
            p.threads = a->threads;
            const auto t0 = std::chrono::steady_clock::now();
            auto lut = skin::generate_lut(p);
            if (!lut) return bake_failed("skin-lut", lut.error());
            const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
            if (auto ok = skin::save_lut(a->output, *lut, a->alpha); !ok) return bake_failed("skin-lut", ok.error());
            std::printf("wrote %s: skin LUT %s, hash %s, generated in %.1f ms\n", a->output.c_str(), p.describe().c_str(),
                        hex64(lut->hash).c_str(), ms);
            std::printf("layout: x = N·L from -1 to 1, y (top to bottom) = 1/r from 0 to %g per mm; alpha: "
                        "min(0.5 P(N·H, m)^0.1, 1) over x = N·H in [0, 1], y = m in [0, 1]\n",
                        p.max_curvature);
            return 0;
          }};
}

// Per-vertex SSDF visibility compressed by clustered PCA (docs/ssdf.md): a .wssdf file.
BakeTarget add_ssdf(CLI::App& bake) {
  struct Args {
    std::string scene, output, seeding = "kmeans++", coefficients = "fp32";
    std::uint32_t resolution = 64;
    std::size_t clusters = 64, components = 48, threads = 0;
    double energy = 1.0;
    std::uint64_t seed = 1;
    bool no_center = false, half_basis = false;
  };
  auto a = std::make_shared<Args>();
  auto* sub = bake.add_subcommand("ssdf", "Per-vertex SSDF visibility (Embree), compressed by clustered PCA: a .wssdf file");
  sub->add_option("scene", a->scene, "Scene file (.json, .gltf/.glb or a mesh)")->required();
  sub->add_option("-o,--output", a->output, "Output .wssdf file")->required();
  sub->add_option("--resolution", a->resolution, "n: n x n directions (equal-area octahedral), 1..1024")->capture_default_str();
  sub->add_option("--clusters", a->clusters, "k-means clusters of triangles")->capture_default_str();
  auto* components = sub->add_option("--components", a->components, "Components kept per cluster (m)")->capture_default_str();
  auto* energy = sub->add_option("--energy", a->energy, "Instead of --components: energy fraction kept per cluster, (0, 1]");
  components->excludes(energy);
  sub->add_option("--seeding", a->seeding, "kmeans++ or farthest (the paper's description)")->capture_default_str();
  sub->add_option("--seed", a->seed, "Random seed of the clustering")->capture_default_str();
  sub->add_option("--coefficients", a->coefficients, "Coefficient storage: fp32, fp16 or 8bit")->capture_default_str();
  sub->add_flag("--no-center", a->no_center, "Plain SVD per cluster (the paper), no mean subtracted");
  sub->add_flag("--half-basis", a->half_basis, "Store cluster means and bases as fp16 (they dominate the size)");
  sub->add_option("--threads", a->threads, "Threads (0: all)")->capture_default_str();
  return {sub, [a, energy] {
            auto invalid = [](std::string message) {
              return bake_failed("ssdf", Error{ErrorKind::InvalidArgument, std::move(message)});
            };
            if (a->resolution < 1 || a->resolution > 1024)
              return invalid(weft::format("--resolution {} is outside 1..1024", a->resolution));
            if (a->clusters < 1) return invalid("--clusters must be at least 1");
            ssdf::BakeOptions options;
            options.resolution = a->resolution;
            options.visibility.threads = a->threads;
            auto& c = options.compression;
            c.clusters = a->clusters;
            c.max_components = a->components;
            if (energy->count() > 0) {
              if (!(a->energy > 0.0 && a->energy <= 1.0))
                return invalid(weft::format("--energy {} is outside (0, 1]", a->energy));
              c.energy_fraction = a->energy;
              c.max_components = 0xffffffffu;
            }
            if (a->seeding == "kmeans++") c.seeding = cluster::Seeding::KMeansPlusPlus;
            else if (a->seeding == "farthest") c.seeding = cluster::Seeding::FarthestPoint;
            else return invalid(weft::format("unknown --seeding '{}' (kmeans++, farthest)", a->seeding));
            if (a->coefficients == "fp32") c.coefficients = cluster::CoefficientFormat::Float32;
            else if (a->coefficients == "fp16") c.coefficients = cluster::CoefficientFormat::Float16;
            else if (a->coefficients == "8bit") c.coefficients = cluster::CoefficientFormat::Unorm8;
            else return invalid(weft::format("unknown --coefficients '{}' (fp32, fp16, 8bit)", a->coefficients));
            c.seed = a->seed;
            c.center = !a->no_center;
            c.half_basis = a->half_basis;
            c.threads = a->threads;
            auto loaded = scene::load_scene(std::filesystem::path(a->scene));
            if (!loaded) return bake_failed("ssdf", loaded.error());
            auto baked = ssdf::bake(*loaded, options);
            if (!baked) return bake_failed("ssdf", baked.error());
            const auto asset = ssdf::make_asset(a->resolution, c, baked->compressed.cpca);
            if (auto ok = ssdf::write_file(a->output, asset); !ok) return bake_failed("ssdf", ok.error());
            const auto error = ssdf::measure_error(baked->raw, baked->compressed.cpca, a->threads);
            const double raw_mb = double(baked->raw.values.size()) * 4.0 / 1048576.0;
            const double packed_mb = double(baked->compressed.cpca.compressed_bytes()) / 1048576.0;
            std::printf("wrote %s: %zu vertices x %u^2 directions, %zu clusters, %zu components in all\n", a->output.c_str(),
                        baked->mesh.vertex_count(), a->resolution, baked->compressed.cpca.clusters.size(),
                        baked->compressed.cpca.total_components());
            std::printf("size: raw %.1f MB -> %.1f MB (%.2f %% smaller); SSDF RMSE %.4f rad, sign errors %.3f %%\n", raw_mb,
                        packed_mb, 100.0 * (1.0 - packed_mb / raw_mb), error.rmse, 100.0 * error.sign_error_rate);
            std::printf("time: visibility %.2f s, distance transform %.2f s, CPCA %.2f s\n", baked->timings.visibility_s,
                        baked->timings.distance_s, baked->timings.compression_s);
            return 0;
          }};
}

}  // namespace

Command add_bake(CLI::App& app) {
  auto* bake = app.add_subcommand("bake", "Precompute an asset into a file (LUTs, baked data)");
  bake->require_subcommand(1);
  auto targets = std::make_shared<std::vector<BakeTarget>>();
  targets->push_back(add_skin_lut(*bake));
  targets->push_back(add_ssdf(*bake));
  targets->push_back(add_bake_btf(*bake));
  return [targets] {
    for (auto& [sub, run] : *targets)
      if (sub->parsed()) return run();
    return 1;
  };
}

}  // namespace weft::cli
