// weft.ssdf — the CPU side of SSDF lighting: per-vertex visibility over a direction grid
// (Embree), the signed spherical distance function (SSDF) from it by a fast distance
// transform, its clustered-PCA compression, and the versioned .wssdf file the lighting pass
// loads. SSDF(ω) = +(angle to the nearest occluded direction sample) where ω is unoccluded,
// −(angle to the nearest unoccluded sample) where occluded; ±π when nothing is of the other
// kind. Module of its own (not the pass) so bakes need no GPU.
module;
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.ssdf;
import weft.core;
import weft.cluster;
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
