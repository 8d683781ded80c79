// weft.btf — a bidirectional texture function as data: per texel, the RGB reflectance for
// every measured (light, view) direction pair (the texel's "ABRDF"). Directions are in the
// surface's tangent frame (z = normal). No GPU: loaders, the synthetic generator,
// preprocessing and clustering run in bakes, tests and benchmarks (docs/neural-btf.md, "Data").
//
// Decisions a user may want to know:
// - A sample is what a rectified database image holds: reflected radiance for a light of unit
//   irradiance at normal incidence, i.e. BRDF x cos θ_light (the cosine is in the data, as in
//   UBO2003 / UTIA photographs). A renderer multiplies by the light's radiance, nothing more.
// - 8-bit database images are sRGB-decoded to linear; UTIA's OpenEXR files are CIE XYZ (D65)
//   and are converted to linear sRGB (out-of-gamut negatives clamped to 0).
// - Direction sets keep their order; loaders sort by (θ, φ), which for the UBO2003 sampling
//   is the order of ubo2003_directions().
module;
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string_view>
#include <vector>
export module weft.btf;
import weft.core;
import weft.image;

export namespace weft::btf {

// A direction in the tangent frame: θ from the normal (0 … π/2), φ around it (radians).
struct Direction {
  float theta = 0.0f;
  float phi = 0.0f;
};
[[nodiscard]] vec3 to_vector(Direction d);  // unit, z = cos θ

// The UBO2003 / UTIA sampling: θ = 0°, 15°, …, 75° with 1, 6, 12, 18, 20, 24 azimuths
// (81 directions), φ evenly spaced from 0. Used for both lights and views.
[[nodiscard]] std::vector<Direction> ubo2003_directions();

// Linear RGB samples, texel-major: rgb[((texel * lights + l) * views + v) * 3 + c], with
// texel = y * width + x. One texel's block of lights * views * 3 floats is its ABRDF.
struct Btf {
  std::uint32_t width = 0, height = 0;
  std::vector<Direction> lights, views;
  std::vector<float> rgb;

  [[nodiscard]] std::size_t texels() const { return std::size_t(width) * height; }
  [[nodiscard]] std::size_t samples_per_texel() const { return lights.size() * views.size(); }
  [[nodiscard]] std::size_t abrdf_floats() const { return samples_per_texel() * 3; }
  [[nodiscard]] std::span<const float> abrdf(std::size_t texel) const {
    return std::span<const float>(rgb).subspan(texel * abrdf_floats(), abrdf_floats());
  }
  [[nodiscard]] std::span<float> abrdf(std::size_t texel) {
    return std::span<float>(rgb).subspan(texel * abrdf_floats(), abrdf_floats());
  }
};


// Where a direction's name is needed in an error: "θ 45°, φ 120°".
[[nodiscard]] std::string describe(Direction d);

// ---- checks and helpers ----------------------------------------------------------------

// Sizes consistent (rgb holds texels * lights * views * 3 floats, no empty dimension) and
// every sample finite and >= 0. Errors (InvalidArgument) name `source` (a file, or what made
// the BTF), the texel (x, y), the light and view (index and angles) and the value.
[[nodiscard]] Result<void> validate(const Btf& btf, std::string_view source);

// The sample of `texel` for light index `l` and view index `v`.
[[nodiscard]] vec3 sample(const Btf& btf, std::size_t texel, std::size_t l, std::size_t v);

// A rectangle of texels; width or height 0 means "to the right / bottom edge".
struct Crop {
  std::uint32_t x = 0, y = 0, width = 0, height = 0;
};
// The texels inside `crop` (InvalidArgument when it does not fit, naming both sizes).
[[nodiscard]] Result<Btf> crop(const Btf& btf, const Crop& crop);
// The same texels with only the chosen light and view indices (in the given order), e.g. to
// hold directions out of training. Out-of-range index: InvalidArgument.
[[nodiscard]] Result<Btf> select_directions(const Btf& btf, std::span<const std::size_t> lights,
                                            std::span<const std::size_t> views);

// Mean Rec.709 luminance of one ABRDF (lights * views * 3 floats), and of every texel's
// (the per-texel scale of the clustered model).
[[nodiscard]] float abrdf_luminance(std::span<const float> abrdf);
[[nodiscard]] std::vector<float> mean_luminance(const Btf& btf);
// RMSE of the best constant prediction, each channel's mean over every sample: what a model
// that learnt nothing scores, the baseline a fit is judged against.
[[nodiscard]] double constant_rmse(const Btf& btf);
// Root mean square difference over every sample and channel. Different sizes or
// directions: InvalidArgument.
[[nodiscard]] Result<double> rmse(const Btf& a, const Btf& b);
// RMSE of `model(texel, light, view)` (unit tangent-frame vectors of the measured directions)
// against the BTF; runs on `threads` threads (0: all), so the callback must be thread-safe.
using ReflectanceFn = std::function<vec3(std::size_t texel, const vec3& light, const vec3& view)>;
[[nodiscard]] double rmse(const Btf& reference, const ReflectanceFn& model, std::size_t threads = 0);

// The BTF as an image for one (light, view) index pair: one pixel per texel, linear RGB.
[[nodiscard]] image::Image texel_image(const Btf& btf, std::size_t l, std::size_t v);

// ---- the synthetic BTF ----------------------------------------------------------------
//
// A procedural fabric height field rendered for every (light, view) pair: woven yarns
// (cylindrical cross-sections undulating over and under each other) or a knitted stockinette
// (V-shaped loops), fibre twist ridges, per-yarn colour with jitter and noise, darker cavities.
// Each texel averages subsamples x subsamples points: GGX specular (height-correlated Smith
// masking, Schlick Fresnel) + Lambert, times cos θ_light on the local normal, times soft
// self-shadowing and masking found by ray-marching the height field toward the light and the
// view, weighted by each point's projected area toward the view. Lengths are in texels.
// Deterministic for a seed, whatever the thread count.

enum class Weave : std::uint8_t { Plain, Twill, Knit };  // Twill: 3/1, the denim weave
[[nodiscard]] std::string_view to_string(Weave weave);
// "plain", "twill" or "knit" (InvalidArgument naming the text otherwise).
[[nodiscard]] Result<Weave> parse_weave(std::string_view text);

struct SyntheticOptions {
  std::uint32_t width = 100, height = 100;  // texels
  std::vector<Direction> lights = ubo2003_directions(), views = ubo2003_directions();
  Weave weave = Weave::Twill;
  std::uint64_t seed = 1;
  float yarn_spacing = 10.0f;   // texels between neighbouring yarns (knit: the wale width)
  float yarn_width = 0.9f;      // fraction of the spacing a yarn covers (woven)
  float relief = 0.4f;          // crown height over the gaps, in yarn spacings; 0: flat
  float fibre_detail = 0.12f;   // twist ridges, as a fraction of the relief
  vec3 warp_color{0.08f, 0.13f, 0.32f};  // linear albedo (knit: the yarn colour)
  vec3 weft_color{0.62f, 0.60f, 0.55f};
  float color_jitter = 0.12f;      // per-yarn relative colour variation
  float albedo_noise = 0.15f;      // relative albedo noise along the fibres
  float cavity_darkening = 0.5f;   // albedo factor lost in the deepest gaps (0: none)
  float roughness = 0.35f;         // GGX alpha
  float specular = 0.04f;          // Fresnel reflectance at normal incidence
  bool shadowing = true;           // self-shadowing and masking from the height field
  std::uint32_t subsamples = 2;    // points per texel and axis
  std::size_t threads = 0;         // 0: all cores
};
// InvalidArgument for a zero size, no directions, a direction below the horizon or a
// parameter out of range (named with its value).
[[nodiscard]] Result<Btf> synthetic_btf(const SyntheticOptions& options);

// The generator's BRDF on a flat surface with normal z: (albedo / π + D G F / (4 cos θ_l
// cos θ_v)) cos θ_l, for unit tangent-frame light and view (0 below the horizon). The flat
// synthetic BTF (relief 0, one colour, no jitter/noise/cavities) equals this at every sample.
[[nodiscard]] vec3 microfacet_reflectance(const vec3& albedo, float roughness, float specular, const vec3& light,
                                          const vec3& view);

// ---- files ------------------------------------------------------------------------------
//
// UBO2003 (Bonn): one image per (light, view) pair, named "<index> tl<θl> pl<φl> tv<θv>
// pv<φv>.jpg" (angles as 3-digit degrees, e.g. "00008 tl000 pl000 tv030 pv030.jpg"), in the
// folder or in per-view subfolders "tv030_pv030/"; JPEG or PNG, 8-bit sRGB.
// UTIA: "tl000_pl000_tv000_pv000.png" (or .exr, CIE XYZ), in per-view subfolders
// "tv000_pv000/" or flat. Both must hold the full light x view grid (a missing pair is a
// Parse error naming it); all images the same size. The crop selects the texels (image
// pixels, top row first). Images are decoded in parallel.
// .btfraw: weft's cache of any BTF (save_btf): little-endian header "WEFTBTFR", version,
// sizes, directions, then float32 samples in Btf's layout, with FNV-1a checksums of the
// header and the payload.
// Every loader validates the result and names the file or folder in every error.
inline constexpr std::uint32_t kBtfRawVersion = 1;

[[nodiscard]] Result<Btf> load_ubo2003(const std::filesystem::path& folder, const Crop& crop = {});
[[nodiscard]] Result<Btf> load_utia(const std::filesystem::path& folder, const Crop& crop = {});
// A .btfraw file, or a folder in either database layout (detected from the file names).
[[nodiscard]] Result<Btf> load_btf(const std::filesystem::path& path_or_folder, const Crop& crop = {});
// Writes a .btfraw (via a temporary file renamed over `file`). Size mismatch: InvalidArgument.
[[nodiscard]] Result<void> save_btf(const Btf& btf, const std::filesystem::path& file);

// ---- reference sampling -----------------------------------------------------------------

// The raw BTF at any light and view (tangent frame, need not be unit): per direction set,
// the 3 nearest measured directions (chord distance d) weighted by 1/d² − 1/d₄² (d₄: the
// 4th nearest), so a weight reaches 0 exactly when its direction leaves the nearest 3 and
// the result is continuous; exact at measured directions. Light and view weights combine
// bilinearly over the 3 x 3 samples. With fewer than 4 directions, plain 1/d² weights.
[[nodiscard]] vec3 sample_reference(const Btf& btf, std::size_t texel, const vec3& light, const vec3& view);

struct DirectionWeights {
  std::size_t count = 0;  // 1..3
  std::size_t index[3] = {0, 0, 0};
  float weight[3] = {0, 0, 0};  // sum 1
};
// The interpolation weights sample_reference uses for one direction set.
[[nodiscard]] DirectionWeights interpolation_weights(std::span<const Direction> measured, const vec3& direction);

// ---- preprocessing (the paper's) --------------------------------------------------------

// inputs = (log(x + 1) − mean) / std per dimension (each of the abrdf_floats() values of an
// ABRDF) over the texels; a dimension with std 0 gets std 1. targets = rgb / target_max,
// target_max the largest sample (1 when all are 0).
struct Preprocessing {
  std::vector<float> mean, std;  // abrdf_floats() each
  float target_max = 1.0f;
};
struct Preprocessed {
  Preprocessing constants;
  std::vector<float> inputs;   // texels * abrdf_floats
  std::vector<float> targets;  // texels * abrdf_floats
};
[[nodiscard]] Preprocessed preprocess(const Btf& btf);
// Only the constants (no copies of the data).
[[nodiscard]] Preprocessing preprocessing_constants(const Btf& btf);
// One ABRDF (e.g. a cluster's median) through the input transform: out = (log(x+1) − mean) / std.
void preprocess_input(const Preprocessing& constants, std::span<const float> abrdf, std::span<float> out);

// ---- clustering (the paper's) -----------------------------------------------------------

enum class ClusterSeeding : std::uint8_t { KMeansPlusPlus, FarthestPoint };

struct ClusterOptions {
  std::uint32_t clusters = 500;
  std::uint32_t pca_components = 16;
  std::uint64_t seed = 1;
  ClusterSeeding seeding = ClusterSeeding::KMeansPlusPlus;
  // The PCA basis is fitted on this many texels drawn with the seed (0: all): an exact PCA
  // of 10,000 x 19,683 needs a 10,000² eigen decomposition; every texel is then projected.
  std::uint32_t pca_sample_texels = 2000;
  std::uint32_t max_iterations = 100;  // Lloyd iterations
  std::size_t threads = 0;
};

struct Clustering {
  std::vector<std::uint32_t> ids;       // per texel, in [0, count())
  std::vector<float> medians;           // count() * abrdf_floats, raw rgb: the element-wise median ABRDF
  std::vector<std::uint32_t> medoids;   // per cluster: the member texel nearest (L2, raw rgb) to the median
  std::vector<std::uint32_t> sizes;     // per cluster: its texels (every cluster has at least one)
  std::uint32_t pca_components = 0;     // components used (at most the rank)
  double pca_energy = 0.0;              // fraction of all texels' centred input energy they hold
  std::size_t iterations = 0;
  [[nodiscard]] std::uint32_t count() const { return static_cast<std::uint32_t>(medoids.size()); }
};
// PCA of the preprocessed inputs, k-means on the coefficients, medians of the raw rgb.
// Clusters left empty (fewer distinct ABRDFs than clusters) are dropped, so count() can be
// below options.clusters. clusters 0 or above the texel count, pca_components 0, or an
// invalid BTF: InvalidArgument.
[[nodiscard]] Result<Clustering> cluster_abrdfs(const Btf& btf, const ClusterOptions& options);

}  // namespace weft::btf
