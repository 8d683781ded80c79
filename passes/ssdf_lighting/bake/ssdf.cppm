// weft.ssdf — the CPU side of SSDF lighting: per-vertex visibility over a direction grid
// (Embree), the signed spherical distance function (SSDF) from it by a fast distance
// transform, its clustered-PCA compression, and the versioned .wssdf file the lighting pass
// loads. SSDF(ω) = +(angle to the nearest occluded direction sample) where ω is unoccluded,
// −(angle to the nearest unoccluded sample) where occluded; ±π when nothing is of the other
// kind. Module of its own (not the pass) so bakes need no GPU.
module;
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.ssdf;
import weft.core;
import weft.cluster;
import weft.image;
import weft.scene;

export namespace weft::ssdf {

// ---- directions ------------------------------------------------------------------------

// n x n directions on the sphere through Clarberg's equal-area octahedral map: every cell
// covers 4π/n² steradians, so plain averages over cells are solid-angle averages. Cell
// (i, j) (column i, row j) has index j * n + i; its centre is the square point
// ((i + ½) 2/n − 1, (j + ½) 2/n − 1). Neighbours are the up-to-8 cells around a cell in the
// square, folded across its edges the way the map folds (the lower hemisphere's edges meet).
class DirectionGrid {
 public:
  explicit DirectionGrid(std::uint32_t n);  // n >= 1 (clamped)

  [[nodiscard]] std::uint32_t resolution() const { return n_; }
  [[nodiscard]] std::size_t size() const { return directions_.size(); }
  [[nodiscard]] const vec3& direction(std::size_t cell) const { return directions_[cell]; }
  [[nodiscard]] std::span<const vec3> directions() const { return directions_; }
  // Neighbour cells of `cell` (distinct, not the cell itself).
  [[nodiscard]] std::span<const std::uint32_t> neighbours(std::size_t cell) const;
  // The cell whose square area contains the direction (need not be unit).
  [[nodiscard]] std::size_t cell_of(const vec3& direction) const;
  // The mean angular spacing of cell centres: sqrt(4π / n²) radians.
  [[nodiscard]] float spacing() const;
  // Bilinear interpolation between the four cell centres around a direction in the square
  // (cells past the square's edge folded as the map folds): sum weights[t] * value(cells[t]).
  struct Taps {
    std::array<std::uint32_t, 4> cells{};
    std::array<float, 4> weights{};
  };
  [[nodiscard]] Taps bilinear(const vec3& direction) const;

 private:
  std::uint32_t n_;
  std::vector<vec3> directions_;
  std::vector<std::uint32_t> neighbour_offsets_;  // size() + 1 prefix offsets
  std::vector<std::uint32_t> neighbour_cells_;
};

// The equal-area octahedral map: square [-1, 1]² <-> unit sphere (+Z in the centre, −Z at
// the corners).
[[nodiscard]] vec3 square_to_sphere(vec2 p);
[[nodiscard]] vec2 sphere_to_square(const vec3& direction);

// ---- visibility ------------------------------------------------------------------------

// Every object's mesh in world space, merged: the occluders, and one probe per vertex.
struct BakeMesh {
  std::vector<vec3> positions;
  std::vector<vec3> normals;           // unit, per vertex
  std::vector<std::uint32_t> indices;  // triangle list
  [[nodiscard]] std::size_t vertex_count() const { return positions.size(); }
  [[nodiscard]] std::size_t triangle_count() const { return indices.size() / 3; }
};
// Objects placed by their transforms (normals by the inverse transpose).
[[nodiscard]] Result<BakeMesh> merge_scene(const scene::Scene& scene);

// A point whose visibility is baked; rays leave from position + offset * normal.
struct Probe {
  vec3 position;
  vec3 normal;
};

struct VisibilityOptions {
  float offset = 1e-4f;       // ray origin offset along the normal, times the scene's bounding
                              // box diagonal (absolute when the scene is empty)
  std::size_t threads = 0;    // 0 = hardware concurrency
  bool progress = true;       // log progress on long bakes
  // Directions below the probe's tangent plane (n·ω < 0) count as unoccluded without a ray.
  // The lighting bake sets it: its lobe integrals already hold the clamped cosine, which
  // removes those directions, so an occluded lower hemisphere would darken every lobe near
  // the horizon a second time (a flat floor would look shadowed everywhere).
  bool below_horizon_visible = false;
};

// visible[p * directions + d] = 1 when the ray from probe p along direction d reaches the
// sky, 0 when it hits a triangle (Embree's rtcOccluded1).
struct Visibility {
  std::size_t probe_count = 0;
  std::size_t directions = 0;
  std::vector<std::uint8_t> visible;
  [[nodiscard]] std::span<const std::uint8_t> of(std::size_t probe) const {
    return {visible.data() + probe * directions, directions};
  }
};
// Errors: indices out of range, non-finite positions, Embree device failures.
[[nodiscard]] Result<Visibility> bake_visibility(const BakeMesh& occluders, std::span<const Probe> probes,
                                                 const DirectionGrid& grid, const VisibilityOptions& options = {});
// Ray queries against a triangle mesh (one Embree scene), shared by the bake and the
// Monte-Carlo reference. Thread-safe for queries once built.
class RayScene {
 public:
  // Errors: indices out of range, non-finite positions, Embree device failures.
  static Result<RayScene> build(const BakeMesh& mesh);
  RayScene(RayScene&&) noexcept;
  RayScene& operator=(RayScene&&) noexcept;
  ~RayScene();
  // Whether the ray origin + t dir (t in (0, inf)) hits a triangle.
  [[nodiscard]] bool occluded(const vec3& origin, const vec3& direction) const;
  struct Hit {
    std::uint32_t triangle = 0;
    float t = 0.0f, u = 0.0f, v = 0.0f;  // barycentrics of vertices 1 and 2
  };
  [[nodiscard]] std::optional<Hit> intersect(const vec3& origin, const vec3& direction) const;
  // The scene's bounding box diagonal (1 when empty): the unit of ray offsets.
  [[nodiscard]] float diagonal() const;

 private:
  RayScene() = default;
  struct State;
  std::unique_ptr<State> state_;
};

// The probes of a mesh: one per vertex.
[[nodiscard]] std::vector<Probe> vertex_probes(const BakeMesh& mesh);

// ---- distance transform ----------------------------------------------------------------

// The SSDF of one probe from its visibility (grid.size() values each). Fast: a Dijkstra-
// ordered propagation of nearest opposite-kind samples over the neighbour graph, each cell
// keeping the candidate whose true angle is smallest — O(D log D), exact except where the
// nearest sample is not reached through neighbours that share it (measured in docs/ssdf.md).
void signed_distance(const DirectionGrid& grid, std::span<const std::uint8_t> visible, std::span<float> out);
// The O(D²) reference: the true nearest opposite-kind sample for every cell.
void signed_distance_exact(const DirectionGrid& grid, std::span<const std::uint8_t> visible, std::span<float> out);
// All probes (rows) in parallel; `exact` picks the reference.
[[nodiscard]] cluster::Matrix signed_distances(const DirectionGrid& grid, const Visibility& visibility,
                                               std::size_t threads = 0, bool exact = false, bool progress = true);

// ---- compression -----------------------------------------------------------------------

struct CompressOptions {
  std::size_t clusters = 64;  // k-means over triangle centroids (clamped to the triangle count)
  cluster::Seeding seeding = cluster::Seeding::KMeansPlusPlus;
  std::uint64_t seed = 1;
  std::size_t max_components = 48;  // per cluster
  double energy_fraction = 1.0;     // per cluster; the paper's other setting: 0.9
  bool center = true;
  cluster::CoefficientFormat coefficients = cluster::CoefficientFormat::Float32;
  bool half_basis = false;  // means and bases in fp16
  std::size_t threads = 0;
};

// The SSDFs of a mesh's vertices (rows of `ssdf`) compressed per cluster of triangles. A
// vertex belongs to the cluster most of its triangles belong to (ties: the lower id; a
// vertex in no triangle: cluster 0), so it is stored once.
struct Compressed {
  std::vector<std::uint32_t> triangle_cluster;
  cluster::Cpca cpca;
};
[[nodiscard]] Result<Compressed> compress(const BakeMesh& mesh, const cluster::Matrix& ssdf,
                                          const CompressOptions& options = {});

// Error of a reconstruction against the raw SSDFs: RMSE in radians over every vertex and
// direction (equal-area cells: a solid-angle mean), the fraction whose sign (visibility)
// flips, and the largest absolute error.
struct ErrorStats {
  double rmse = 0.0;
  double sign_error_rate = 0.0;
  double max_abs = 0.0;
};
[[nodiscard]] ErrorStats measure_error(const cluster::Matrix& raw, const cluster::Cpca& cpca, std::size_t threads = 0);
[[nodiscard]] ErrorStats measure_error(const cluster::Matrix& raw, const cluster::Matrix& approximation);

// ---- the whole bake --------------------------------------------------------------------

struct BakeOptions {
  std::uint32_t resolution = 64;  // n: n x n directions
  VisibilityOptions visibility;
  CompressOptions compression;
};
struct BakeTimings {
  double visibility_s = 0.0, distance_s = 0.0, compression_s = 0.0;
};
struct Bake {
  BakeMesh mesh;
  cluster::Matrix raw;  // vertices x directions
  Compressed compressed;
  BakeTimings timings;
};
[[nodiscard]] Result<Bake> bake(const scene::Scene& scene, const BakeOptions& options = {});

// The SSDFs of some objects' vertices (the probes), with every object of the scene as an
// occluder: what the lighting feature bakes for its "ssdf" objects. `objects` are indices
// into scene.objects; the rows follow them in order, each object's vertices in mesh order.
struct ObjectBake {
  BakeMesh probes;        // the probed objects, merged in world space (for clustering)
  cluster::Matrix raw;    // probes' vertices x directions
  Compressed compressed;
  BakeTimings timings;
};
[[nodiscard]] Result<ObjectBake> bake_objects(const scene::Scene& scene, std::span<const std::uint32_t> objects,
                                              const BakeOptions& options = {});
// bake_objects without the compression (`compressed` left empty): for a caller that tries
// several compressions of one bake (weft-bench-ssdf), so that it bakes exactly as the
// lighting feature does.
[[nodiscard]] Result<ObjectBake> bake_object_distances(const scene::Scene& scene,
                                                       std::span<const std::uint32_t> objects,
                                                       const BakeOptions& options = {});
// merge_scene restricted to some objects (in the order given).
[[nodiscard]] Result<BakeMesh> merge_objects(const scene::Scene& scene, std::span<const std::uint32_t> objects);

// ---- the environment as spherical Gaussians ------------------------------------------

// G(ω) = amplitude · exp(sharpness · (axis·ω − 1)), amplitude in linear RGB radiance.
struct SphericalGaussian {
  vec3 axis{0.0f, 1.0f, 0.0f};
  float sharpness = 1.0f;
  vec3 amplitude{0.0f};
};
// ∫ exp(λ(μ·ω − 1)) dω = 2π (1 − e^{−2λ}) / λ; 4π at λ = 0 (computed without cancellation).
[[nodiscard]] double sg_integral(double sharpness);
[[nodiscard]] vec3 evaluate(const SphericalGaussian& lobe, const vec3& direction);
[[nodiscard]] vec3 evaluate(std::span<const SphericalGaussian> lobes, const vec3& direction);
// ∫ G dω per channel.
[[nodiscard]] vec3 energy(const SphericalGaussian& lobe);
[[nodiscard]] vec3 energy(std::span<const SphericalGaussian> lobes);

struct SgFitOptions {
  std::uint32_t lobes = 16;        // N, the quality knob: 1 .. 256
  std::uint32_t max_width = 128;   // the map is reduced to at most this many texel blocks across
  std::uint32_t iterations = 32;   // Lloyd iterations (stops earlier when nothing moves)
  std::uint32_t em_iterations = 30;  // EM refinement of the vMF mixture Lloyd starts
  std::uint64_t seed = 1;          // weighted k-means++ seeding
  float max_sharpness = 1.0e4f;    // a single blazing texel becomes a lobe this sharp
};
// Fits N spherical Gaussians to an equirectangular map (weft.scene's mapping, rotated by
// `rotation_degrees`, scaled by `intensity`): texel blocks, each carrying its exact solid-
// angle-weighted energy and mean direction, are clustered by weighted k-means on the sphere
// (luminance energy as weight, k-means++ seeding with a fixed seed); the clusters start a
// mixture of von Mises–Fisher lobes refined by EM (an SG is a vMF density times a scale);
// each component becomes one lobe with its mean direction, the vMF sharpness of its mean
// resultant length, and the amplitude that gives it its exact share of the RGB energy. So the lobes' total energy equals the map's (up to float rounding), a map
// that is one SG is recovered by N = 1, an all-zero map gives zero lobes (finite, no NaN),
// and one blazing texel gives one lobe of max_sharpness holding its energy. Always returns
// exactly N lobes (the unused ones with zero amplitude).
[[nodiscard]] Result<std::vector<SphericalGaussian>> fit_environment(const image::Image& equirect,
                                                                     const SgFitOptions& options = {},
                                                                     float rotation_degrees = 0.0f,
                                                                     float intensity = 1.0f);
// The scene's environment: its map, or a constant colour (a uniform 64 x 32 map).
[[nodiscard]] Result<std::vector<SphericalGaussian>> fit_environment(const scene::Environment& environment,
                                                                     const SgFitOptions& options = {});
// ∫ L dω of an equirectangular map per channel (texel solid angles exact per row band).
[[nodiscard]] vec3 map_energy(const image::Image& equirect);

// ---- shading (the pass's maths, on the CPU) --------------------------------------------

// The clamped-cosine response of a unit spherical Gaussian, normalised by its integral:
// T(λ, t) = ∫ exp(λ(μ·ω − 1)) max(n·ω, 0) dω / sg_integral(λ) for t = μ·n. It is 1/4 at
// λ = 0 (a constant sky) and max(t, 0) as λ → ∞. Fitted closed forms (Hill's, for one) fail
// for broad lobes (λ < 1), so the pass tabulates it: rows u = λ / (λ + 8) in [0, 1] (the last
// row is λ = ∞), columns t in [−1, 1]; each entry integrates exactly over θ (closed-form
// azimuthal integral of the clamped cosine, 4096-point midpoint rule in θ). The shader reads
// the same table from a storage buffer with the same bilinear lookup as `lookup`.
struct IrradianceTable {
  static constexpr std::uint32_t rows = 64, columns = 128;
  static constexpr float sharpness_midpoint = 8.0f;  // λ at u = 1/2
  std::vector<float> values;                         // rows x columns, row-major
  [[nodiscard]] float lookup(float sharpness, float cosine) const;
};
const IrradianceTable& irradiance_table();
// The exact T(λ, t) by quadrature (what the table holds at its nodes).
[[nodiscard]] double sg_cosine_response(double sharpness, double cosine, std::uint32_t steps = 4096);
// Irradiance ∫ G(ω) max(n·ω, 0) dω of one lobe: energy · T(λ, μ·n) from the table.
[[nodiscard]] vec3 sg_irradiance(const SphericalGaussian& lobe, const vec3& normal);
// The SSDF at a lobe's centre is a sampled distance whose zero crossing lies half a cell
// from the samples on either side; this maps it to a distance to the boundary
// (sign(d) · max(|d| − h, |d| / 2), h = half the grid spacing: continuous and monotone).
[[nodiscard]] float boundary_distance(float ssdf, float half_spacing);
// Fraction of a lobe that is visible when the boundary is `distance` radians from its centre
// (positive: the centre is visible): smoothstep(−w, w, distance) with w = 1.88 / √λ, the
// smooth step whose slope at 0 matches the Gaussian's edge-on cumulative (Wang et al. 2009
// style: the distance against the lobe's angular width).
[[nodiscard]] float lobe_visibility(float distance, float sharpness);
// Outgoing diffuse radiance factor at a point: (1/π) Σ_j sg_irradiance(j, n) V_j, so a Lambert
// surface of albedo a returns a · this. `ssdf_at_lobes[j]` is the SSDF at lobe j's axis.
[[nodiscard]] vec3 shade_diffuse(std::span<const SphericalGaussian> lobes, std::span<const float> ssdf_at_lobes,
                                 const vec3& normal, float half_spacing);
// The SSDF of one row of a CPCA at each lobe axis (bilinear between cells, as the shader).
void ssdf_at_lobes(const cluster::Cpca& cpca, std::size_t row, const DirectionGrid& grid,
                   std::span<const SphericalGaussian> lobes, std::span<float> out);
// Same for a raw SSDF row (directions values).
void ssdf_at_lobes(std::span<const float> ssdf, const DirectionGrid& grid, std::span<const SphericalGaussian> lobes,
                   std::span<float> out);

// ---- Monte-Carlo reference -------------------------------------------------------------

// Radiance arriving from a (unit) direction.
using RadianceFunction = std::function<vec3(const vec3&)>;
struct ReferenceOptions {
  std::uint32_t samples = 1024;  // per point, cosine-weighted, stratified (rounded to a square)
  std::uint64_t seed = 1;
  float offset = 1e-4f;          // ray origin offset along the normal, times the scene diagonal
  std::size_t threads = 0;
  bool progress = true;
};
// (1/π) ∫ L(ω) V(p, ω) max(n·ω, 0) dω at each point, by ray tracing with Embree: what a
// Lambert surface of albedo a reflects is a · this (the pass's shade_diffuse estimates it).
[[nodiscard]] Result<std::vector<vec3>> reference_diffuse(const RayScene& scene, std::span<const Probe> points,
                                                          const RadianceFunction& radiance,
                                                          const ReferenceOptions& options = {});

// A camera image of a scene shaded by that reference: every object Lambert with its albedo
// (by object index; objects without an entry are black), environment lighting ray traced,
// plus an optional directional key light with a ray-traced hard shadow. Pixels the camera
// sees no surface through hold the environment (mask 0).
struct ReferenceCamera {
  mat4 inverse_view_projection{1.0f};  // Vulkan clip space: NDC y = -1 is the top row
  vec3 position{0.0f};
  std::uint32_t width = 64, height = 64;
};
struct ReferenceLight {
  vec3 towards{0.0f, 1.0f, 0.0f};  // unit vector towards the light
  vec3 irradiance{0.0f};           // at normal incidence
};
struct ReferenceImage {
  std::uint32_t width = 0, height = 0;
  std::vector<vec3> radiance;      // row-major, row 0 at the top
  std::vector<std::uint8_t> mask;  // 1 where a surface is seen
  std::vector<std::uint32_t> object;  // object index seen (u32 max: none)
};
[[nodiscard]] Result<ReferenceImage> reference_image(const scene::Scene& scene, const ReferenceCamera& camera,
                                                     std::span<const vec3> albedo, const RadianceFunction& radiance,
                                                     const std::optional<ReferenceLight>& light,
                                                     const ReferenceOptions& options = {});

// ---- the .wssdf file -------------------------------------------------------------------

// What the lighting pass loads: the compressed SSDFs of every vertex (in merge_scene's
// order) and the knobs they were made with.
struct Asset {
  std::uint32_t resolution = 0;
  std::uint32_t requested_clusters = 0;
  std::uint32_t requested_components = 0;  // max_components (u32 max: no limit)
  float requested_energy = 1.0f;
  cluster::Cpca cpca;
};
[[nodiscard]] Asset make_asset(std::uint32_t resolution, const CompressOptions& options, cluster::Cpca cpca);

inline constexpr std::uint32_t kFileVersion = 1;
// Version 1, little-endian: a 64-byte header (magic "WEFTSSDF", version, header size,
// resolution, directions, vertices, clusters, coefficient format, flags, requested
// components and energy, section count, FNV-1a-64 of the header) then sections, each
// {u32 tag, u32 0, u64 size, u64 FNV-1a-64 of the payload, payload}: "VTX\0" (cluster and
// slot per vertex, u32 each) and "CLS\0" (per cluster: rows, components, mean (when the
// centred flag is set), basis (fp16 when the half-basis flag is set, else fp32), 8-bit
// offsets and scales, coefficients in the header's format). See docs/ssdf.md.
[[nodiscard]] std::vector<std::byte> encode(const Asset& asset);
// Parse errors name what is wrong: truncation (what was being read and how many bytes were
// missing), bad magic, unsupported version (ErrorKind::Unsupported), checksum mismatch
// (header or which section), inconsistent sizes. Never reads out of bounds.
[[nodiscard]] Result<Asset> decode(std::span<const std::byte> bytes, std::string_view source = "ssdf data");
[[nodiscard]] Result<void> write_file(const std::filesystem::path& path, const Asset& asset);
[[nodiscard]] Result<Asset> read_file(const std::filesystem::path& path);

}  // namespace weft::ssdf
