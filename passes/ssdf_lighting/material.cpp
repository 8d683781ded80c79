// The "ssdf" material's fields, read with scene::JsonReader so every problem names its JSON
// path, and the bake cache: .wssdf files keyed by the scene's content and the bake knobs.
module;
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <glm/glm.hpp>
#include <weft/try.h>
#include <nlohmann/json.hpp>
module weft.pass.ssdf_lighting;
import weft.cluster;

namespace weft::ssdf {

std::string_view to_string(ShadingMode mode) { return mode == ShadingMode::Vertex ? "vertex" : "pixel"; }

namespace {

// Bumped when the bake's output changes for the same knobs (part of the cache key).
constexpr std::uint32_t kBakeRevision = 1;

void read_bake(scene::JsonReader& r, BakeOptions& bake) {
  const auto& knobs = passes::ssdf_lighting_feature().knobs;
  bake.resolution = std::uint32_t(read_integer_knob(r, *find_knob(knobs, "bake.resolution"), bake.resolution));
  auto& c = bake.compression;
  c.clusters = std::size_t(read_integer_knob(r, *find_knob(knobs, "bake.clusters"), std::int64_t(c.clusters)));
  if (r.has("components")) c.max_components = std::size_t(read_integer_knob(r, *find_knob(knobs, "bake.components"), 16));
  c.energy_fraction = r.number("energy", c.energy_fraction, {.min = 0, .max = 1, .min_exclusive = true});
  c.seeding = r.string("seeding", "kmeans++", {"kmeans++", "farthest"}) == "farthest" ? cluster::Seeding::FarthestPoint
                                                                                      : cluster::Seeding::KMeansPlusPlus;
  c.seed = std::uint64_t(r.integer("seed", std::int64_t(c.seed), {.min = 0, .max = 9007199254740991.0}));
  const std::string format = read_choice_knob(r, *find_knob(knobs, "bake.coefficients"), "fp32");
  c.coefficients = format == "fp16"   ? cluster::CoefficientFormat::Float16
                   : format == "8bit" ? cluster::CoefficientFormat::Unorm8
                                      : cluster::CoefficientFormat::Float32;
  c.half_basis = r.boolean("half_basis", c.half_basis);
  c.center = r.boolean("center", c.center);
  r.finish();
}

}  // namespace

SsdfQualityPreset ssdf_quality_preset(Quality q) {
  switch (q) {
    case Quality::Low: return {16, 8};
    case Quality::Medium: return {32, 16};
    case Quality::High: return {64, 32};
    case Quality::Reference: return {64, 48};
  }
  return {};
}

Result<SsdfMaterial> parse_ssdf_material(const scene::Material& material, Quality quality) {
  SsdfMaterial m;
  const SsdfQualityPreset q = ssdf_quality_preset(quality);
  m.lobes = q.lobes;
  m.bake.resolution = q.resolution;
  // Defaults from docs/ssdf.md's table: 32 clusters (k-means++) of 16 components keep the
  // sign error near 0.4 % at ~97 % smaller, and bake in tens of seconds, not minutes.
  m.bake.compression.clusters = 32;
  m.bake.compression.max_components = 16;
  m.bake.visibility.progress = true;
  m.bake.visibility.below_horizon_visible = true;  // the clamped cosine handles the horizon
  WEFT_TRY_VOID(read_material_fields(material, "ssdf", [&](scene::JsonReader& r) {
    m.albedo = r.vec3_of("albedo", m.albedo, {.min = 0, .max = 1});
    const auto& knobs = passes::ssdf_lighting_feature().knobs;
    m.shading = read_choice_knob(r, *find_knob(knobs, "shading"), "pixel") == "vertex" ? ShadingMode::Vertex
                                                                                        : ShadingMode::Pixel;
    m.lobes = std::uint32_t(read_integer_knob(r, *find_knob(knobs, "lobes"), m.lobes));
    if (auto bake = r.object("bake")) read_bake(*bake, m.bake);
  }));
  return m;
}

std::uint64_t bake_key(const scene::Scene& scene, std::span<const std::uint32_t> objects, const BakeOptions& options) {
  Hasher h;
  h.value(kBakeRevision).value(kFileVersion);
  h.value(std::uint64_t(scene.objects.size()));
  for (const auto& object : scene.objects) {
    h.value(object.transform);
    if (object.mesh < scene.meshes.size()) h.value(mesh_content_hash(scene.meshes[object.mesh]));
  }
  h.value(std::uint64_t(objects.size()));
  for (auto o : objects) h.value(o);
  const auto& c = options.compression;
  h.value(options.resolution).value(options.visibility.offset).value(options.visibility.below_horizon_visible);
  h.value(std::uint64_t(c.clusters)).value(c.seeding).value(c.seed).value(std::uint64_t(c.max_components));
  h.value(c.energy_fraction).value(c.center).value(c.coefficients).value(c.half_basis);
  return h.digest();
}

std::filesystem::path bake_cache_dir() {
  if (const char* dir = std::getenv("WEFT_SSDF_CACHE")) return *dir ? std::filesystem::path(dir) : std::filesystem::path();
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::filesystem::path(xdg) / "weft" / "ssdf";
  if (const char* home = std::getenv("HOME"); home && *home) return std::filesystem::path(home) / ".cache" / "weft" / "ssdf";
  return {};
}

Result<CachedBake> cached_bake(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                               const BakeOptions& options) {
  const std::uint64_t key = bake_key(scene, objects, options);
  const std::filesystem::path dir = bake_cache_dir();
  CachedBake result;
  if (!dir.empty()) result.file = dir / ("ssdf-" + hex64(key) + ".wssdf");
  if (!result.file.empty() && std::filesystem::exists(result.file)) {
    auto asset = read_file(result.file);
    if (asset && asset->resolution == options.resolution) {
      result.asset = std::move(*asset);
      result.from_disk = true;
      return result;
    }
    log::warn(weft::format("SSDF cache: ignoring '{}' ({}); baking again", result.file.string(),
                           asset ? "its resolution differs" : asset.error().message));
  }
  WEFT_TRY(auto baked, bake_objects(scene, objects, options));
  result.asset = make_asset(options.resolution, options.compression, std::move(baked.compressed.cpca));
  if (!result.file.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    // write_file is atomic: a concurrent reader or writer never meets half a file.
    if (auto ok = write_file(result.file, result.asset); !ok) log::warn(weft::format("SSDF cache: {}", ok.error().message));
  }
  return result;
}

}  // namespace weft::ssdf
