// weft.pass.ssdf_lighting — image-based lighting with SSDF visibility (the GPU side of
// docs/ssdf.md): the environment as N spherical Gaussians, each lobe's visibility at a vertex
// from its compressed SSDF at the lobe's centre against the lobe's angular width (Wang et al.
// 2009), Lambert shading, plus the key light's direct term through the shadow map. The
// SSDFs are baked (weft.ssdf) for the scene's "ssdf" objects with every object as an
// occluder, cached by content hash as .wssdf files, and their CPCA bases and coefficients
// live in storage buffers; the shaders reconstruct the SSDF at the N lobe centres per vertex
// (a few taps of m components each, independent of the direction resolution) and shade per
// vertex or per pixel.
module;
#include <functional>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>
namespace CLI {
class App;  // what a bake command adds its options to
}
export module weft.pass.ssdf_lighting;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;
import weft.feature;
import weft.ssdf;

export namespace weft::ssdf {

// Where the SSDF is evaluated: "vertex" shades each vertex (the vertex shader sums the
// lobes, the colour is interpolated); "pixel" interpolates the SSDF at the lobe centres
// (reconstructed per vertex) and shades each pixel with its own normal.
enum class ShadingMode : std::uint8_t { Vertex, Pixel };
std::string_view to_string(ShadingMode mode);

inline constexpr std::uint32_t max_lobes = 48;  // the pixel mode interpolates 12 vec4s

// An "ssdf" material's fields (docs/ssdf.md lists them with JSON names and ranges).
struct SsdfMaterial {
  vec3 albedo{0.8f};  // linear RGB Lambert albedo
  ShadingMode shading = ShadingMode::Pixel;
  std::uint32_t lobes = 16;  // spherical Gaussians for the environment, 1 .. max_lobes
  BakeOptions bake;          // resolution and compression (visibility options at defaults)
};

// What a quality preset sets when the material does not: the bake's direction resolution
// (n x n per vertex) and the environment's lobes.
struct SsdfQualityPreset {
  std::uint32_t resolution = 32, lobes = 16;
};
SsdfQualityPreset ssdf_quality_preset(Quality quality);

// Reads a material's params with scene::JsonReader: every problem in one Parse error at its
// JSON path. `quality` picks the defaults the material does not set (ssdf_quality_preset):
// direction resolution (low 16, medium 32, high and reference 64) and lobes (8, 16, 32, 48).
Result<SsdfMaterial> parse_ssdf_material(const scene::Material& material, Quality quality = Quality::Medium);

// The content key of a bake: every object's mesh and transform (all are occluders), which
// objects are probed, and the bake knobs that change the result (not the thread count).
std::uint64_t bake_key(const scene::Scene& scene, std::span<const std::uint32_t> objects, const BakeOptions& options);
// $WEFT_SSDF_CACHE (empty: no disk cache), else $XDG_CACHE_HOME/weft/ssdf, else
// ~/.cache/weft/ssdf. Files are named ssdf-<key>.wssdf.
std::filesystem::path bake_cache_dir();
struct CachedBake {
  Asset asset;
  bool from_disk = false;
  std::filesystem::path file;  // empty without a disk cache
};
// The .wssdf for these objects: read from the cache folder when there (a corrupt file is
// reported in the log and baked again), else baked and written there.
Result<CachedBake> cached_bake(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                               const BakeOptions& options);

}  // namespace weft::ssdf

export namespace weft::passes {

// A .wssdf on the GPU, all values as fp32: "vertex_table" (cluster, slot per vertex),
// "cluster_table" (components, coefficient, basis and mean offsets per cluster; mean offset
// u32 max when not centred) and "data" (means, bases, coefficients).
struct SsdfGpuAsset {
  gpu::Buffer vertex_table, cluster_table, data;
  std::uint32_t resolution = 0, directions = 0, vertex_count = 0;
  std::uint64_t bytes = 0;  // GPU memory of the three buffers
};
Result<SsdfGpuAsset> upload_ssdf(gpu::Device& device, const ssdf::Asset& asset, std::string_view label);

// The lobes for one direction grid: axis, sharpness, energy, visibility width and the four
// bilinear taps of the axis in the grid (64 bytes each).
struct SsdfGpuLobes {
  gpu::Buffer buffer;
  std::uint32_t count = 0, resolution = 0;
};
Result<SsdfGpuLobes> upload_lobes(gpu::Device& device, std::span<const ssdf::SphericalGaussian> lobes,
                                  std::uint32_t resolution, std::string_view label);

// One object the pass draws.
struct SsdfDraw {
  const frame::GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  const SsdfGpuAsset* asset = nullptr;
  const SsdfGpuLobes* lobes = nullptr;  // same resolution as the asset
  std::uint32_t base_vertex = 0;        // the object's first row in the asset
  vec3 albedo{0.8f};
  ssdf::ShadingMode shading = ssdf::ShadingMode::Pixel;
};

// The graph pass "ssdf_lighting": draws into "scene_color"/"scene_depth" (loading what the
// forward pass drew), reading "frame_uniforms" and "shadow_map" and the imported buffers.
class SSDFLightingPass {
 public:
  static Result<SSDFLightingPass> create(gpu::Device& device);
  // `draws` and what they point to must outlive the graph's execution.
  Result<void> add(RenderGraph& graph, std::span<const SsdfDraw> draws) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The feature: material type "ssdf_lighting" (alias "ssdf"), its knob table, its FeaturePass.
const FeatureDescriptor& ssdf_lighting_feature();

}  // namespace weft::passes

// The feature's `weft bake ssdf` command (its descriptor's `bakes`); not exported.
namespace weft::passes::detail {
std::function<int()> add_ssdf_bake(CLI::App& command);
}  // namespace weft::passes::detail
