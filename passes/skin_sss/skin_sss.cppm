// weft.pass.skin_sss — pre-integrated skin (Penner 2011) with the curvature-adaptive
// integration range of Gao's thesis (eq. 3.1): subsurface scattering pre-integrated over a
// ring of radius r into one RGBA lookup table (RGB: diffuse D(N·L, 1/r); A: the Beckmann
// distribution of the Kelemen/Szirmay-Kalos specular), so shading costs a few fetches.
// Also here: the brute-force references the LUT is measured against, transmittance through
// thin parts from the shadow map (Jimenez et al. 2010), and the FeaturePass that draws
// "skin" materials (docs/skin.md has the method, the conventions chosen and measurements).
//
// Units: the diffusion profile is in millimetres, so curvature is in 1/mm; a material's
// `mm_per_unit` converts scene units (metres by default: 1000).
//
// LUT layout (chosen so that the extremes are exact texels, not interpolations):
// - diffuse, texel (i, j): N·L = -1 + 2 i / (W - 1), 1/r = max_curvature * j / (H - 1);
//   row 0 is the flat limit (1/r = 0): exactly max(N·L, 0);
// - alpha, texel (i, j): N·H = i / (W - 1), m = j / (H - 1), holding
//   encode_beckmann(beckmann(N·H, m)) = min(0.5 * P^0.1, 1) (GPU Gems 3 ch. 14's encoding);
// - a shader maps a value x in [0, 1] to the texture coordinate (x (W - 1) + 0.5) / W, so
//   with bilinear filtering and clamp-to-edge the end points hit texel centres.
// Memory row 0 is the first row of the texture and the top row of a saved image.
module;
#include <functional>
#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
namespace CLI {
class App;  // what a bake command adds its options to
}
export module weft.pass.skin_sss;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.feature;

export namespace weft::skin {

using dvec3 = glm::dvec3;

// ---- the diffusion profile ------------------------------------------------------------

// One Gaussian of the sum-of-Gaussians profile: variance in mm², RGB weights.
struct ProfileGaussian {
  double variance = 0.0;
  dvec3 weight{0.0};
};

// d'Eon & Luebke's six Gaussians fitted to the three-layer skin dipole (GPU Gems 3 ch. 14);
// the weights of each channel sum to 1.
std::span<const ProfileGaussian> skin_profile();

// How a Gaussian is normalised, which sets the Gaussians' relative weights:
// Planar: 1/(2πv), a 2-D density (the thesis, eq. 2.2; d'Eon's definition);
// Ring:   1/√(2πv), a 1-D density (Penner's listing; the ring integral is 1-D).
enum class Normalization : std::uint8_t { Planar, Ring };
std::string_view to_string(Normalization n);

struct ProfileConvention {
  Normalization normalization = Normalization::Ring;
  double variance_scale = 1.0;  // every variance is multiplied by this (Penner: 1.414)
  friend bool operator==(const ProfileConvention&, const ProfileConvention&) = default;
};
inline constexpr ProfileConvention thesis_convention{Normalization::Planar, 1.0};
inline constexpr ProfileConvention penner_convention{Normalization::Ring, 1.414};
// The convention weft's LUTs use by default: measured closest to the brute-force sphere
// reference (docs/skin.md, "Which normalisation").
inline constexpr ProfileConvention default_convention{Normalization::Ring, 1.414};
// The profile as measured: d'Eon's planar Gaussians, variances unscaled (the references).
inline constexpr ProfileConvention physical_convention{Normalization::Planar, 1.0};

// R(d) per channel, d in mm.
dvec3 profile(double distance_mm, ProfileConvention convention = physical_convention,
              std::span<const ProfileGaussian> gaussians = skin_profile());
// Jimenez et al.'s transmittance through a slab of `thickness_mm`: Σ w_i exp(-s²/v_i),
// 1 at s = 0, falling off fastest in blue.
dvec3 transmittance(double thickness_mm, std::span<const ProfileGaussian> gaussians = skin_profile());

// ---- the ring integral (the LUT's definition) ----------------------------------------

// Penner: x in [-π/2, π/2]. Adaptive (the thesis, eq. 3.1): x in ±π(r+1)/(2r), 2π at r = 1
// mm and π as r grows (capped at ±π: a ring has no more). Full: the whole ring, ±π.
enum class IntegrationRange : std::uint8_t { Penner, Adaptive, Full };
std::string_view to_string(IntegrationRange range);
Result<IntegrationRange> integration_range_from_string(std::string_view name);
// Half the integration interval for a ring of radius r (mm; +inf allowed).
double half_range(IntegrationRange range, double radius_mm);

// PerGaussian: each Gaussian gets its own midpoint grid over the part of the range where it
// is not negligible (|chord| <= 6σ), so narrow Gaussians on large rings stay resolved.
// Uniform: one midpoint grid over the whole range for all Gaussians (Penner's loop).
enum class Quadrature : std::uint8_t { PerGaussian, Uniform };
std::string_view to_string(Quadrature q);

struct RingOptions {
  IntegrationRange range = IntegrationRange::Adaptive;
  ProfileConvention convention = default_convention;
  std::uint32_t samples = 256;  // per Gaussian (PerGaussian) or in all (Uniform); >= 2
  Quadrature quadrature = Quadrature::PerGaussian;
};

// D(θ, r) = ∫ cos⁺(θ + x) R(2r sin(x/2)) dx / ∫ R(2r sin(x/2)) dx over the range, per
// channel, for cos θ in [-1, 1] (clamped) and r in mm (r = +inf or 1/r -> 0: max(cos θ, 0)).
// In [0, 1]; where the quadrature catches none of the profile, the flat limit.
dvec3 integrate_ring(double cos_theta, double radius_mm, const RingOptions& options = {});

// ---- the Kelemen/Szirmay-Kalos specular ----------------------------------------------

// GPU Gems 3 ch. 14's Beckmann term P(N·H, m) = exp(-tan²α/m²) / (m² cos⁴α) (no 1/π);
// 0 for N·H <= 0 or m <= 0 (except the delta at N·H = 1, m = 0: +inf).
double beckmann(double n_dot_h, double m);
// What the LUT's alpha stores: min(0.5 P^0.1, 1) (8-bit friendly; exact up to P = 1024).
double encode_beckmann(double p);
double decode_beckmann(double encoded);  // pow(2 e, 10)
double fresnel_schlick(double v_dot_h, double f0 = 0.028);
// The KS specular BRDF times N·L: N·L ρ_s P(N·H, m) F(V·H) / |L + V|² (with unnormalised
// half vector L + V); 0 when N·L <= 0. The pass divides it by π like its diffuse term.
double ks_specular(const dvec3& n, const dvec3& l, const dvec3& v, double m, double rho_s, double f0 = 0.028);

// ---- the LUT ---------------------------------------------------------------------------

struct LutParams {
  std::uint32_t width = 256;   // N·L (and N·H) texels, 2 .. 4096
  std::uint32_t height = 256;  // curvature (and roughness) texels, 2 .. 4096
  IntegrationRange range = IntegrationRange::Adaptive;
  ProfileConvention convention = default_convention;
  double max_curvature = 1.0;  // 1/r (1/mm) of the last row; (0, 10]
  std::uint32_t samples = 256;  // ring quadrature samples, 2 .. 65536
  Quadrature quadrature = Quadrature::PerGaussian;
  std::uint32_t threads = 0;   // 0: every hardware thread; not part of the content hash

  // Content hash of everything that changes the texels (stable across runs and machines).
  [[nodiscard]] std::uint64_t hash() const;
  // "256x256 adaptive ring/1 max 1/mm 256 samples per-gaussian"
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] RingOptions ring() const { return {range, convention, samples, quadrature}; }
};
// InvalidArgument naming the field when a knob is out of range.
Result<void> validate(const LutParams& params);

struct SkinLut {
  LutParams params;
  std::uint32_t width = 0, height = 0;
  std::vector<vec4> texels;  // row-major, row 0 first
  std::uint64_t hash = 0;    // params.hash()

  [[nodiscard]] const vec4& texel(std::uint32_t x, std::uint32_t y) const { return texels[std::size_t(y) * width + x]; }
  // The N·L and 1/r of a texel's centre (see the layout above).
  [[nodiscard]] double n_dot_l_at(std::uint32_t x) const;
  [[nodiscard]] double curvature_at(std::uint32_t y) const;
};

// Pure and deterministic: the same params give bit-identical texels for any thread count.
Result<SkinLut> generate_lut(const LutParams& params);

// The shader's lookups, on the CPU: bilinear, clamp-to-edge, with the texel-centre mapping.
vec3 sample_diffuse(const SkinLut& lut, float n_dot_l, float curvature_per_mm);
float sample_specular(const SkinLut& lut, float n_dot_h, float m);  // decoded P(N·H, m)
// The texture coordinate of x in [0, 1] (clamped) on an axis of `texels` texels.
float lut_coordinate(float x, std::uint32_t texels);

// RGBA float image (alpha: the encoded Beckmann term).
image::Image to_image(const SkinLut& lut);
// .exr: RGBA float32 as stored. .png: sRGB-encoded for viewing, RGB (diffuse) unless
// `with_alpha`; values are linear in the LUT, so a PNG is a picture, not the data.
Result<void> save_lut(const std::filesystem::path& path, const SkinLut& lut, bool with_alpha = false);

// Process-wide LUT cache keyed by LutParams::hash(): memory first, then (if a folder is
// set) EXR files named skin-lut-<hash>.exr. The folder is $WEFT_SKIN_LUT_CACHE (empty
// disables the disk), else $XDG_CACHE_HOME/weft/skin-lut, else ~/.cache/weft/skin-lut.
struct LutCacheStats {
  std::uint64_t memory_hits = 0, disk_hits = 0, generated = 0;
};
Result<std::shared_ptr<const SkinLut>> cached_lut(const LutParams& params);
LutCacheStats lut_cache_stats();
void clear_lut_memory_cache();
std::filesystem::path lut_disk_cache_dir();

// ---- brute-force references ------------------------------------------------------------

// Brute-force subsurface scattering on a sphere of radius r (mm) lit by a distant light at
// angle θ from the point's normal: every surface point q gathers cos⁺ irradiance weighted
// by R(|p - q|), divided by the weight (so uniform light gives 1, as in the LUT):
//   B = Σ_i w_i ∫_S G_i E dA / Σ_i w_i ∫_S G_i dA.
// The azimuthal integral is closed-form; the polar one is a `samples`-point midpoint rule
// per Gaussian after the substitution s = 1 - exp(-d²/2v). r = +inf gives max(cos θ, 0).
dvec3 sphere_reference(double cos_theta, double radius_mm, ProfileConvention convention = physical_convention,
                       std::uint32_t samples = 4096);

struct MeshReferenceOptions {
  vec3 towards_light{0.0f, 0.0f, 1.0f};  // unit vector towards a distant light (mesh space)
  double mm_per_unit = 1000.0;           // mesh units to mm
  ProfileConvention convention = physical_convention;
  double min_cell_mm = 0.02;  // finest quadrature cell (the narrowest Gaussian has σ = 0.08)
  double refine = 8.0;        // a cell at distance d is split until smaller than d / refine
  std::uint32_t threads = 0;
};
// The same gather on a triangle mesh, for each vertex: every triangle within 6σ of the
// widest Gaussian is split recursively (finer near the vertex) and each cell contributes
// at its centroid with the interpolated normal. No shadowing (as in the LUT).
Result<std::vector<vec3>> mesh_reference(const scene::Mesh& mesh, const MeshReferenceOptions& options);

// ---- the skin material -----------------------------------------------------------------

enum class CurvatureSource : std::uint8_t { Vertex, Screen };
enum class DebugView : std::uint8_t { None, Curvature, Diffuse, Transmittance, Thickness };
std::string_view to_string(CurvatureSource c);
std::string_view to_string(DebugView d);

// A "skin" material's fields (docs/skin.md lists them with their JSON names and ranges).
struct SkinMaterial {
  vec3 albedo{0.84f, 0.6f, 0.5f};        // linear RGB diffuse albedo
  std::filesystem::path albedo_texture;  // sRGB; multiplies albedo
  std::filesystem::path normal_texture;  // tangent space detail normals (+Y towards the image's top)
  std::filesystem::path specular_texture;  // grey, linear: multiplies `specular` (ρ_s) per texel
  float normal_strength = 1.0f;
  // How much of the geometric (blurred) normal each channel uses instead of the detail
  // normal: red scatters furthest, so it sees the smoothest surface.
  vec3 normal_blur{0.9f, 0.6f, 0.4f};
  float roughness = 0.3f;   // Beckmann m
  float specular = 0.18f;   // ρ_s
  float mm_per_unit = 1000.0f;
  float curvature_scale = 1.0f;  // multiplies the curvature before the lookup (artistic)
  CurvatureSource curvature = CurvatureSource::Vertex;
  bool transmittance = true;
  float transmittance_scale = 1.0f;  // multiplies the thickness (mm) before the profile
  float transmittance_shrink_mm = 0.3f;  // inset along the normal before the shadow lookup
  // The diffuse term ignores occluders nearer than the local sphere's chord along the light
  // (the LUT already has that self-shadowing) plus this margin (mm), which covers faceted
  // meshes and lets light scattered a short way reach into cast shadows' edges.
  float shadow_scatter_mm = 2.0f;
  DebugView debug_view = DebugView::None;
  // Shade with brute-force scattering per vertex (mesh_reference) instead of the LUT; the
  // Reference preset turns it on unless the material says otherwise. Slow: for studies.
  bool reference = false;
  LutParams lut;
};

// What a quality preset sets when the material does not: the LUT's size and ring samples,
// and (at Reference) the brute-force mode. Chosen from `weft tradeoff --feature skin`
// (docs/tradeoffs.md).
struct SkinQualityPreset {
  std::uint32_t lut_size = 256, lut_samples = 256;
  bool reference = false;
};
SkinQualityPreset skin_quality_preset(Quality quality);

// Reads a scene material's params (scene::Material::params at json_path) with JsonReader:
// every problem in one Parse error, each at its JSON path. `quality` picks the LUT size and
// sample count unless the material sets them (skin_quality_preset).
Result<SkinMaterial> parse_skin_material(const scene::Material& material, Quality quality = Quality::Medium);

}  // namespace weft::skin

export namespace weft::passes {

// One object the skin pass draws, ready for the GPU.
struct SkinDraw {
  const frame::GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  std::uint32_t material = 0;  // index into the materials given to SkinSSSPass::add
  // The reference mode: one vec4 per vertex of brute-force diffuse (mesh_reference for the
  // key light), used instead of the LUT's RGB; null: the LUT.
  const gpu::Buffer* reference = nullptr;
};

// A skin material on the GPU: its parameters and its bind group (LUT, albedo and normal
// textures), built by SkinSSSPass::create_material.
struct SkinGpuMaterial {
  skin::SkinMaterial params;
  gpu::BindGroup group;
  int flags = 0;
};

// The graph pass: draws skin objects into "scene_color"/"scene_depth" (loading what the
// forward pass drew), reading "frame_uniforms", "shadow_map" and "environment".
class SkinSSSPass {
 public:
  static Result<SkinSSSPass> create(gpu::Device& device);
  // Textures must outlive the material (the feature owns them).
  Result<std::shared_ptr<SkinGpuMaterial>> create_material(gpu::Device& device, const skin::SkinMaterial& material,
                                                           const gpu::Texture& lut, const gpu::Texture& albedo,
                                                           const gpu::Texture& normal, const gpu::Texture& specular) const;
  // `draws` and `materials` must outlive the graph's execution; `luts` are the LUT
  // textures the materials sample (imported and declared as reads).
  Result<void> add(RenderGraph& graph, std::span<const SkinDraw> draws,
                   std::span<const std::shared_ptr<SkinGpuMaterial>> materials,
                   std::span<const gpu::Texture* const> luts) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The feature: material type "skin_sss" (alias "skin"), its knob table, its FeaturePass. At
// Quality::Reference the FeaturePass shades with skin::mesh_reference per vertex instead of
// the LUT (computed on the CPU for the frame's key light, cached per mesh, light and scale).
const FeatureDescriptor& skin_sss_feature();

}  // namespace weft::passes

// The feature's `weft bake skin-lut` command (its descriptor's `bakes`); not exported.
namespace weft::passes::detail {
std::function<int()> add_skin_lut_bake(CLI::App& command);
}  // namespace weft::passes::detail
