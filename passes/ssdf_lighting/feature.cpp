// The "ssdf" FeaturePass: parses the materials, bakes (or loads from the cache) one SSDF per
// set of bake knobs for the objects using them, with every scene object as an occluder, fits
// the environment's spherical Gaussians, uploads both once, and draws each frame.
module;
#include <chrono>
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <weft/try.h>
module weft.pass.ssdf_lighting;

namespace weft::passes {

namespace {

// The environment's content: what changes its lobes.
std::uint64_t environment_key(const scene::Environment& env, std::uint32_t lobes) {
  Hasher h;
  h.value(lobes).value(env.intensity).value(env.rotation_degrees).value(env.constant_color);
  if (env.map) {
    h.value(env.map->width).value(env.map->height).value(env.map->channels);
    h.bytes(env.map->pixels.data(), env.map->pixels.size() * sizeof(float));
  }
  return h.digest();
}

class SsdfFeature final : public FeaturePass {
 public:
  // The factory the descriptor names: the graph pass first, then the feature around it.
  static Result<std::unique_ptr<FeaturePass>> create(gpu::Device& device) {
    WEFT_TRY(auto pass, SSDFLightingPass::create(device));
    return std::make_unique<SsdfFeature>(device, std::move(pass));
  }

  SsdfFeature(gpu::Device& device, SSDFLightingPass pass) : device_(&device), pass_(std::move(pass)) {}

  [[nodiscard]] std::string_view name() const override { return "ssdf_lighting"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    draws_.clear();
    warnings_.clear();
    // Materials, and the objects grouped by bake knobs (one bake per group).
    std::vector<ssdf::SsdfMaterial> materials;
    std::vector<std::pair<std::uint32_t, ssdf::SsdfMaterial>> objects;
    WEFT_TRY_VOID(resolve_materials(
        frame, materials, [&](const scene::Material& material) { return material_for(material, frame.quality); },
        [&](std::uint32_t object_index, std::uint32_t slot) { objects.emplace_back(object_index, materials[slot]); }));
    std::map<std::uint64_t, std::vector<std::uint32_t>> groups;  // by knobs
    std::map<std::uint64_t, ssdf::BakeOptions> group_options;
    for (const auto& [index, material] : objects) {
      const std::uint64_t knobs = ssdf::bake_key(scene::Scene{}, {}, material.bake);
      groups[knobs].push_back(index);
      group_options[knobs] = material.bake;
    }
    // Bakes: memory, then disk, then bake.
    std::map<std::uint32_t, std::pair<const SsdfGpuAsset*, std::uint32_t>> placement;  // object -> asset, base
    for (const auto& [knobs, members] : groups) {
      const ssdf::BakeOptions& options = group_options.at(knobs);
      const std::uint64_t key = ssdf::bake_key(frame.scene, members, options);
      auto it = assets_.find(key);
      if (it == assets_.end() && device_->declaring()) {
        // A declared frame (no adapter): the asset's buffers without the bake. The vertex
        // table has its size; the cluster table and data, whose sizes only the bake knows,
        // are placeholders.
        ssdf::Asset placeholder;
        placeholder.resolution = options.resolution;
        placeholder.cpca.cols = std::size_t(options.resolution) * options.resolution;
        for (std::uint32_t index : members)
          placeholder.cpca.row_count += frame.scene.meshes.at(frame.scene.objects.at(index).mesh).positions.size();
        placeholder.cpca.cluster_of.assign(placeholder.cpca.row_count, 0);
        placeholder.cpca.slot_of.assign(placeholder.cpca.row_count, 0);
        WEFT_TRY(auto uploaded, upload_ssdf(*device_, placeholder, "ssdf." + hex64(key)));
        it = assets_.emplace(key, std::make_unique<SsdfGpuAsset>(std::move(uploaded))).first;
      }
      if (it == assets_.end()) {
        const auto start = std::chrono::steady_clock::now();
        auto baked = ssdf::cached_bake(frame.scene, members, options);
        if (!baked) return with_context("ssdf bake", baked.error());
        log::info(weft::format("ssdf: {} ({} vertices, {}x{} directions, {} clusters) in {:.1f} s{}",
                               baked->from_disk ? "loaded the cached SSDF" : "baked the SSDF",
                               baked->asset.cpca.row_count, options.resolution, options.resolution,
                               baked->asset.cpca.clusters.size(),
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                               baked->file.empty() ? std::string() : " (" + baked->file.string() + ")"));
        WEFT_TRY(auto uploaded, upload_ssdf(*device_, baked->asset, "ssdf." + hex64(key)));
        it = assets_.emplace(key, std::make_unique<SsdfGpuAsset>(std::move(uploaded))).first;
      }
      std::uint32_t base = 0;
      for (std::uint32_t index : members) {
        placement[index] = {it->second.get(), base};
        base += std::uint32_t(frame.scene.meshes.at(frame.scene.objects.at(index).mesh).positions.size());
      }
    }
    // Lobes per (environment, lobe count, resolution), and the draws.
    for (const auto& [index, material] : objects) {
      const scene::Object& object = frame.scene.objects.at(index);
      auto lobes = lobes_for(frame.scene.environment, material.lobes, material.bake.resolution);
      if (!lobes) return with_context(weft::format("ssdf object '{}': environment fit", object.name), lobes.error());
      const auto [asset, base] = placement.at(index);
      draws_.push_back({frame.meshes[object.mesh], object.transform, asset, *lobes, base, material.albedo,
                        material.shading});
    }
    if (!frame.scene.environment.map && frame.scene.environment.constant_color == vec3(0.0f))
      warnings_.push_back("ssdf materials under a black environment show only the key light");
    return {};
  }

  Result<void> add_passes(RenderGraph& graph, const FeatureFrame&) override { return pass_.add(graph, draws_); }

  [[nodiscard]] std::vector<std::string> warnings() const override { return warnings_; }

 private:
  Result<ssdf::SsdfMaterial> material_for(const scene::Material& material, Quality quality) {
    Hasher h;
    h.str(material.name).str(material.params.dump()).str(material.json_path).value(std::uint8_t(quality));
    const std::uint64_t key = h.digest();
    if (auto it = materials_.find(key); it != materials_.end()) return it->second;
    WEFT_TRY(auto parsed, ssdf::parse_ssdf_material(material, quality));
    materials_.emplace(key, parsed);
    return parsed;
  }

  Result<const SsdfGpuLobes*> lobes_for(const scene::Environment& env, std::uint32_t count, std::uint32_t resolution) {
    const std::uint64_t fit_key = environment_key(env, count);
    const auto key = std::pair{fit_key, resolution};
    if (auto it = lobes_.find(key); it != lobes_.end()) return it->second.get();
    auto fit = fits_.find(fit_key);
    if (fit == fits_.end() && device_->declaring())  // a declared frame: no fit, the buffer at its size
      fit = fits_.emplace(fit_key, std::vector<ssdf::SphericalGaussian>(count)).first;
    if (fit == fits_.end()) {
      WEFT_TRY(auto lobes, ssdf::fit_environment(env, {.lobes = count}));
      fit = fits_.emplace(fit_key, std::move(lobes)).first;
    }
    WEFT_TRY(auto uploaded, upload_lobes(*device_, fit->second, resolution, weft::format("ssdf.lobes{}x{}", count, resolution)));
    return lobes_.emplace(key, std::make_unique<SsdfGpuLobes>(std::move(uploaded))).first->second.get();
  }

  gpu::Device* device_;
  SSDFLightingPass pass_;
  std::map<std::uint64_t, ssdf::SsdfMaterial> materials_;                     // by params + quality
  std::map<std::uint64_t, std::unique_ptr<SsdfGpuAsset>> assets_;             // by bake key
  std::map<std::uint64_t, std::vector<ssdf::SphericalGaussian>> fits_;        // by environment + count
  std::map<std::pair<std::uint64_t, std::uint32_t>, std::unique_ptr<SsdfGpuLobes>> lobes_;  // + resolution
  // This frame's draws, alive until the graph has executed.
  std::vector<SsdfDraw> draws_;
  std::vector<std::string> warnings_;
};

}  // namespace

// Quality picks bake.resolution and lobes (16/8, 32/16, 64/32, 64/48); docs/ssdf.md.
const FeatureDescriptor& ssdf_lighting_feature() {
  static const FeatureDescriptor feature{
      .name = "ssdf_lighting", .aliases = {"ssdf"}, .doc = "docs/ssdf.md",
      .summary = "soft environment shadows from a baked spherical signed distance field (SSDF)",
      .check_material = check_by_parsing<&ssdf::parse_ssdf_material>, .create = &SsdfFeature::create,
      .passes = {"ssdf_lighting"},
      // The stability sweep's bake extremes stop where a bake of a showcase-sized mesh stays
      // within minutes on two cores.
      .knobs = {
          integer_knob("lobes", 1, ssdf::max_lobes, {1, 4, 8, 16, 32, 48}, "spherical Gaussians the environment is fitted with"),
          choice_knob("shading", {"vertex", "pixel"}, "sum the lobes per vertex, or interpolate the SSDF and shade per pixel"),
          with_extremes(integer_knob("bake.resolution", 2, 256, {8, 16, 32, 64}, "SSDF directions per vertex: n x n (equal-area octahedral)"),
                        4, 64),
          with_extremes(integer_knob("bake.clusters", 1, 65536, {1, 8, 32, 128}, "CPCA clusters of triangles"),
                        std::nullopt, 256),
          with_extremes(integer_knob("bake.components", 0, 65536, {0, 2, 8, 16, 48}, "principal components kept per cluster"),
                        std::nullopt, 256),
          choice_knob("bake.coefficients", {"fp32", "fp16", "8bit"}, "how the per-vertex coefficients are stored"),
      },
      .preset_values = [](Quality q) -> nlohmann::json {
        const auto p = ssdf::ssdf_quality_preset(q);
        return {{"bake.resolution", p.resolution}, {"lobes", p.lobes}};
      },
      // The finest bake the sweep reaches, uncompressed in effect (components beyond the rank
      // keep every one), with the most lobes: what remains is the SG fit and the visibility
      // approximation themselves. The ray-traced Monte-Carlo reference (weft-bench-ssdf
      // --lighting) measures those; docs/ssdf.md has its numbers.
      .reference = {{"lobes", ssdf::max_lobes}, {"shading", "pixel"}, {"bake.resolution", 64},
                     {"bake.clusters", 32}, {"bake.components", 256}, {"bake.coefficients", "fp32"}},
      .reference_why = "64 x 64 directions, 256 components (full rank), fp32, 48 lobes, per pixel: only the SG "
                        "fit and the visibility model remain",
      .cost = CostAxis::Frame,
      .grids = {{"lobes", "shading"}},
      .bakes = {{.name = "ssdf", .summary = "Per-vertex SSDF visibility (Embree), compressed by clustered PCA: a .wssdf file", .add = &detail::add_ssdf_bake}},
  };
  return feature;
}

}  // namespace weft::passes
