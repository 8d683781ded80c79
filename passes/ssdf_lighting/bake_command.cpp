// `weft bake ssdf SCENE -o out.wssdf [--resolution n] [--clusters k] [--components m | --energy f] ...`:
// per-vertex SSDF visibility compressed by clustered PCA (docs/ssdf.md). The feature's
// descriptor offers it to `weft bake` (FeatureDescriptor::bakes).
module;
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <CLI/CLI.hpp>
module weft.pass.ssdf_lighting;
import weft.core;
import weft.cluster;
import weft.scene;
import weft.ssdf;

namespace weft::passes::detail {

std::function<int()> add_ssdf_bake(CLI::App& command) {
  struct Args {
    std::string scene, output, seeding = "kmeans++", coefficients = "fp32";
    std::uint32_t resolution = 64;
    std::size_t clusters = 64, components = 48, threads = 0;
    double energy = 1.0;
    std::uint64_t seed = 1;
    bool no_center = false, half_basis = false;
  };
  auto a = std::make_shared<Args>();
  auto* sub = &command;
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
  sub->add_option("--threads", a->threads, "Threads (0: all)")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t(0), std::size_t(1024)));
  return [a, energy] {
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
          };
}

}  // namespace weft::passes::detail
