// weft.pass.shell_fur — fur from one photograph (Ukaji et al., "Feature extraction and
// real-time rendering of fur from a real photo", after Lengyel et al.'s shells, I3D 2001).
// A top-down photo of single-coloured fur is read as a scattering medium: luminance falls
// off as I = I_max exp(-a h) with depth h, so a texel's luminance says how deep its hair point
// sits. The photo becomes N+1 shells (n = 0 the tips, offset h_b from the skin; n = N the
// skin) without ever making N textures: the GPU holds the photo once plus a small band table,
// and layer n keeps the texels whose luminance falls in its band [I(n), I(n-1)).
//
// Pieces, each usable on its own:
// - the precompute (analyze_fur_photo, make_band_table, ...): pure functions, tested on the CPU;
// - ShellFurPass: draws fur objects into "scene_color"/"scene_depth" with one instanced draw
//   per object (gl_InstanceIndex = layer), plus silhouette fins;
// - shell_fur_feature: the descriptor an application registers for "shell_fur" materials.
//
// Decisions (see docs/fur.md for the reasons and measurements):
// - Luminance is Rec. 709 luminance of the sRGB-decoded photo, stored per texel as an 8-bit
//   "luminance code" (the sRGB curve applied to it) in the photo texture's alpha; every
//   keep boundary is placed half a code between two codes, so the CPU tables and the GPU
//   agree on every texel. The darkening target is the band's exact top luminance I(n-1).
// - Bands are half-open and partition the luminance axis: layer 0 takes I >= I_max (the
//   bright outliers too), layer N everything below I(N-1) (the dark outliers too).
// - Band layout (the paper): a texel is drawn in its one layer. Strand layout: also in
//   every deeper layer, so a hair runs from its tip down to the skin. In both, the skin
//   (layer N) is opaque, and a texel drawn below its own band is darkened to the top of that
//   layer's band (the model's luminance at that depth), so gaps show dark under-fur.
// - Shells write depth: kept texels are opaque hair points, so the result is independent of
//   draw order, and the background pass (drawn later where depth is still the far plane)
//   must not paint over fur. Layers are drawn tips first: with h_b = 0 the tips win the
//   depth ties and the fur collapses exactly to the photo on the skin.
module;
#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.pass.shell_fur;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.feature;

// The CPU side (photo analysis, band table, shells, fins, the material) is weft::fur; the
// graph pass is weft::passes::ShellFurPass, beside the other passes.
export namespace weft::fur {

// ---- precompute ------------------------------------------------------------------------

inline constexpr std::uint32_t max_fur_layers = 256;

// Rec. 709 luminance of the sRGB-decoded colour, sRGB-encoded and rounded to 8 bits.
[[nodiscard]] std::uint8_t fur_luminance_code(std::uint8_t r, std::uint8_t g, std::uint8_t b);
// Linear luminance of a (possibly fractional) code in [0, 255].
[[nodiscard]] double fur_code_to_luminance(double code);

// Robust I_min / I_max: the luminance at these fractions of the histogram's mass.
struct FurThresholds {
  double low_percentile = 0.01;
  double high_percentile = 0.99;
};

// What the fur pass needs of a photo: the texture it samples, its luminance statistics, and
// the hair orientation read from its streaks.
struct FurPhoto {
  std::uint32_t width = 0, height = 0;
  // RGBA8, row-major from the top: sRGB colour and, in A, the texel's luminance code.
  std::vector<std::uint8_t> rgba;
  // RG8: the hair direction in image space (x right, y down) as the double angle
  // (cos 2phi, sin 2phi) scaled by the structure tensor's coherence, mapped to [0, 255].
  std::vector<std::uint8_t> orientation;
  std::array<std::uint64_t, 256> histogram{};  // of the luminance codes
  std::uint8_t code_min = 0, code_max = 0;       // the percentile codes (before the floor)
  double i_min = 0.0, i_max = 0.0;               // linear; 0 < i_min <= i_max
  // Otsu's between-class / total variance of the luminance codes: ~0.65-0.75 for one mode,
  // towards 1 for two well-separated populations (two-coloured fur, the method's weak case).
  double bimodality = 0.0;
  std::vector<std::string> notes;  // what was clamped (I_min = 0, uniform photo, ...)
  [[nodiscard]] std::size_t texel_count() const { return std::size_t(width) * height; }
  [[nodiscard]] std::uint8_t code(std::size_t texel) const { return rgba[texel * 4 + 3]; }
};

// The smallest I_min used: the luminance of half a code, so a = ln(I_max/I_min) stays finite
// for photos with black pixels.
[[nodiscard]] double fur_luminance_floor();

// Grey-scales the photo (1-4 channels), builds the histogram, takes I_min and I_max at the
// percentiles, estimates hair orientation. InvalidArgument for an empty/invalid image or
// percentiles outside 0 <= low < high <= 1.
[[nodiscard]] Result<FurPhoto> analyze_fur_photo(const image::Image8& photo, const FurThresholds& thresholds = {});

enum class FurLayout : std::uint8_t { Band, Strand };
[[nodiscard]] std::string_view to_string(FurLayout layout);

// One shell as the shaders see it (std430, 16 bytes), in alpha units (luminance code / 255):
// the interval [keep_min, keep_max) it draws (half a code between two codes); the top of its
// band I(n-1) as a fractional alpha (the sRGB curve of that luminance), above which a texel
// (drawn below its own band) is darkened to exactly I(n-1) (2: never); its height above the
// skin / h_b.
struct FurGpuLayer {
  float keep_min = 0.0f;
  float keep_max = 0.0f;
  float top = 0.0f;
  float height = 0.0f;
};

// Equation 4 and the per-layer keep intervals. Layers n = 0..N (N = `layers`).
struct FurBandTable {
  std::uint32_t layers = 0;
  FurLayout layout = FurLayout::Band;
  double i_max = 0.0, i_min = 0.0;
  std::vector<double> boundaries;      // I(n) = I_max exp(-ln(I_max/I_min) n/N), n = 0..N
  std::vector<std::uint16_t> first_code;  // per n: the smallest code whose luminance >= I(n); 0 for n = N
  std::vector<FurGpuLayer> gpu;        // N+1 entries, uploaded as the band table buffer

  // The layer a texel of this code belongs to: the n with I(n) <= I < I(n-1).
  [[nodiscard]] std::uint32_t depth_layer(std::uint8_t code) const;
  // Whether layer n draws a texel of this code (band: its own layer and the skin; strand:
  // every layer from its own down).
  [[nodiscard]] bool keeps(std::uint32_t layer, std::uint8_t code) const;
};

// InvalidArgument unless 1 <= layers <= 256 and 0 < i_min <= i_max are finite.
[[nodiscard]] Result<FurBandTable> make_band_table(double i_max, double i_min, std::uint32_t layers, FurLayout layout);
// Texels per depth layer (band membership, sums to the texel count).
[[nodiscard]] std::vector<std::uint64_t> depth_layer_counts(const FurPhoto& photo, const FurBandTable& table);
// The attenuation coefficient a = ln(I_max/I_min) / h_b of equation 2: 0 for a uniform photo,
// +infinity for h_b = 0 with contrast (all shells coincide; nothing else uses a).
[[nodiscard]] double fur_attenuation(double i_max, double i_min, double thickness);

// The naive method the paper improves on: one RGBA8 texture per layer (alpha 0/1 = kept),
// colour darkened as the shader would. N+1 images of photo.rgba's size.
[[nodiscard]] std::vector<std::vector<std::uint8_t>> make_shell_textures(const FurPhoto& photo, const FurBandTable& table);

// A procedural top-down fur photo (redistributable, for tests, examples and docs when the
// real photos are absent): curved hair strokes over a dark undercoat, later (higher) hairs
// brighter, in `color` (linear RGB). It tiles: strokes and flow wrap around the edges.
struct FurSynthesis {
  std::uint32_t width = 256, height = 256;
  float coverage = 1.8f;        // hairs over a pixel on average (the undercoat shows where none is)
  float hair_length = 12.0f;    // pixels
  float hair_width = 1.6f;      // pixels
  float flow_degrees = 30.0f;   // mean hair direction in the image
  float flow_waviness = 0.6f;   // how much the direction varies across the image (radians)
  vec3 color{0.75f, 0.62f, 0.45f};
  std::uint32_t seed = 1;
};
[[nodiscard]] image::Image8 synthesize_fur_photo(const FurSynthesis& synthesis = {});

// ---- geometry --------------------------------------------------------------------------

// Silhouette fins (Lengyel et al.): one quad per mesh edge, extruded along the vertex normals
// by h_b; the vertex shader keeps only edges near the silhouette. 88 bytes per edge.
struct FurFinEdge {
  vec3 position_a, position_b;
  vec3 normal_a, normal_b;
  vec4 uv_ab;            // uv of a in xy, of b in zw
  vec3 face_normal_0, face_normal_1;  // the two faces' normals (equal on a boundary)
};
static_assert(sizeof(FurFinEdge) == 88);

// Every edge once (vertices welded by position, so UV seams add no fins); zero-area
// triangles are skipped. `normals` and `uvs` may be empty (zeros are used).
[[nodiscard]] std::vector<FurFinEdge> make_fin_edges(std::span<const vec3> positions, std::span<const vec3> normals,
                                                     std::span<const vec2> uvs, std::span<const std::uint32_t> indices);

enum class FurUvMapping : std::uint8_t { Auto, Mesh, Planar, Spherical };
[[nodiscard]] std::string_view to_string(FurUvMapping mapping);
// Gives a mesh generated UVs (and tangents): planar over its two largest extents, or
// spherical about its centre with u in [0, 2) (seamless under mirrored wrapping; vertices on
// the seam are split). Auto: planar for flat meshes (smallest extent < 10% of the largest),
// spherical otherwise. Mesh: InvalidArgument when the mesh has no UVs.
[[nodiscard]] Result<void> generate_fur_uvs(scene::Mesh& mesh, FurUvMapping mapping);

// ---- the material ----------------------------------------------------------------------

enum class FurLighting : std::uint8_t { Lambert, KajiyaKay };
[[nodiscard]] std::string_view to_string(FurLighting lighting);
enum class FurWrap : std::uint8_t { Mirror, Repeat };

// Layers by quality: Low 8, Medium 15 (the paper), High 32, Reference 64.
[[nodiscard]] std::uint32_t fur_layers_for(Quality quality);

// A "fur" material's fields (docs/fur.md lists them with their JSON names).
struct FurMaterial {
  std::filesystem::path photo;        // required
  std::uint32_t layers = 15;          // N; "layers", else by quality
  bool layers_from_quality = true;
  std::optional<float> thickness;     // h_b in object units; absent: 3% of the mesh's diagonal
  std::optional<float> spacing;       // h_b / N instead of thickness
  vec3 tint{1.0f};                    // multiplies the photo's colour (linear)
  FurLayout layout = FurLayout::Strand;
  FurLighting lighting = FurLighting::KajiyaKay;
  FurThresholds thresholds;
  vec2 uv_scale{1.0f};
  FurWrap wrap = FurWrap::Mirror;
  FurUvMapping uv_mapping = FurUvMapping::Auto;
  std::optional<vec2> comb;           // hair direction in UV space; absent: from the photo
  float lift_degrees = 20.0f;         // hair angle above the surface (Kajiya-Kay tangent)
  float specular = 0.05f;
  float shininess = 50.0f;
  bool fins = true;
  float fin_threshold = 0.35f;        // |N.V| below which an edge grows a fin
  bool per_sample_hair = false;       // "msaa_hair": "per_sample" (default from high quality up) or "coverage"
  // The thickness for a mesh whose bounding-box diagonal is `diagonal`.
  [[nodiscard]] float thickness_for(float diagonal) const;
};

// Reads material.params at material.json_path (paths against material.base_dir). Every
// problem comes back in one Parse error naming "$.materials.<name>.<field>".
[[nodiscard]] Result<FurMaterial> parse_fur_material(const scene::Material& material, Quality quality = Quality::Medium);

}  // namespace weft::fur

namespace weft::passes {
using namespace fur;  // this unit's GPU declarations use the CPU side's types unqualified
}

export namespace weft::passes {

// ---- GPU assets and the pass -------------------------------------------------------------

enum class FurMethod : std::uint8_t {
  SinglePhoto,       // the paper: one photo texture + the band table
  PerLayerTextures,  // the naive shell method: N+1 textures, one draw per layer (benchmarks)
};

struct FurPhotoTexture {
  gpu::Texture photo;        // RGBA8Srgb (A: luminance code)
  gpu::Texture orientation;  // RG8Unorm
  [[nodiscard]] std::uint64_t bytes() const;
};
[[nodiscard]] Result<FurPhotoTexture> upload_fur_photo(gpu::Device& device, const FurPhoto& photo, std::string_view label);

struct FurLayerTable {
  FurBandTable table;
  gpu::Buffer bands;                   // FurGpuLayer[N+1], read-only storage
  std::vector<gpu::Texture> textures;  // PerLayerTextures only: N+1 RGBA8Srgb
  [[nodiscard]] std::uint64_t bytes() const;
};
[[nodiscard]] Result<FurLayerTable> upload_band_table(gpu::Device& device, FurBandTable table, std::string_view label,
                                                      const FurPhoto* photo_for_textures = nullptr);

struct FurFins {
  gpu::Buffer edges;  // FurFinEdge[count], a storage buffer the fin vertex shader reads
  std::uint32_t count = 0;
};
[[nodiscard]] Result<FurFins> upload_fins(gpu::Device& device, std::span<const FurFinEdge> edges, std::string_view label);

// How one object's fur looks (the material, resolved for its mesh).
struct FurShading {
  float thickness = 0.05f;  // h_b, object units
  vec3 tint{1.0f};
  FurLighting lighting = FurLighting::KajiyaKay;
  vec2 uv_scale{1.0f};
  FurWrap wrap = FurWrap::Mirror;
  std::optional<vec2> comb;
  float lift_degrees = 20.0f;
  float specular = 0.05f;
  float shininess = 50.0f;
  float fin_threshold = 0.35f;
};

// One furry object; every pointer must outlive the graph's execution.
struct ShellFurDraw {
  const frame::GpuMesh* mesh = nullptr;     // the skin; its normals and UVs grow the shells
  mat4 model{1.0f};
  const FurPhotoTexture* photo = nullptr;
  const FurLayerTable* layers = nullptr;
  const FurFins* fins = nullptr;            // null: no fins
  FurShading shading;
  FurMethod method = FurMethod::SinglePhoto;
  // Under MSAA, test the hair per sample (each sample its own texel: the hair supersampled,
  // the fur's shading run per sample) where the adapter shades per sample; false: turn alpha
  // into coverage (cheaper, coarser). No effect on a single-sample frame.
  bool per_sample_hair = false;
};

class ShellFurPass {
 public:
  static Result<ShellFurPass> create(gpu::Device& device);
  // One render pass "shell_fur" that loads and writes the blackboard's "scene_color" and
  // "scene_depth" (putting back the new versions), reading "frame_uniforms" and "shadow_map".
  // Photos, band tables and per-layer textures are imported. `draws` must outlive execution.
  Result<void> add(RenderGraph& graph, std::span<const ShellFurDraw> draws) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The feature: material type "shell_fur" (alias "fur"), its knob table, its FeaturePass.
// An application registers it (weft.builtin_features does for weft's tools).
const FeatureDescriptor& shell_fur_feature();

}  // namespace weft::passes
