// The equal-area octahedral direction grid (Clarberg, "Fast equal-area mapping of the
// (hemi)sphere using SIMD", JGT 2008) and its folded 8-neighbourhood.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;

namespace weft::ssdf {
namespace {
constexpr float kQuarterPi = 0.785398163397448f;

// Folds a point of the extended square back into [-1, 1]²: across u = ±1 the map meets
// itself at (±2 − u, −v), and likewise across v = ±1.
vec2 fold(vec2 p) {
  if (p.x > 1.0f) p = {2.0f - p.x, -p.y};
  if (p.x < -1.0f) p = {-2.0f - p.x, -p.y};
  if (p.y > 1.0f) p = {-p.x, 2.0f - p.y};
  if (p.y < -1.0f) p = {-p.x, -2.0f - p.y};
  return p;
}
}  // namespace

vec3 square_to_sphere(vec2 p) {
  const float au = std::abs(p.x), av = std::abs(p.y);
  const float d = 1.0f - (au + av);
  const float r = 1.0f - std::abs(d);
  const float phi = r == 0.0f ? 0.0f : ((av - au) / r + 1.0f) * kQuarterPi;
  const float z = std::copysign(1.0f - r * r, d);
  const float s = r * std::sqrt(std::max(0.0f, 2.0f - r * r));
  return glm::normalize(vec3(std::copysign(std::cos(phi) * s, p.x), std::copysign(std::sin(phi) * s, p.y), z));
}

vec2 sphere_to_square(const vec3& direction) {
  const vec3 d = glm::normalize(direction);
  const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  const float r = std::sqrt(std::max(0.0f, 1.0f - az));
  const float psi = (ax == 0.0f && ay == 0.0f) ? 0.0f : std::atan2(ay, ax) / (2.0f * kQuarterPi);
  float v = psi * r, u = r - v;
  if (d.z < 0.0f) {
    const float fu = 1.0f - v, fv = 1.0f - u;
    u = fu, v = fv;
  }
  return {std::copysign(u, d.x), std::copysign(v, d.y)};
}

DirectionGrid::DirectionGrid(std::uint32_t n) : n_(std::max(1u, n)) {
  const std::size_t count = std::size_t(n_) * n_;
  directions_.resize(count);
  const float cell = 2.0f / float(n_);
  auto centre = [&](int i, int j) { return vec2((float(i) + 0.5f) * cell - 1.0f, (float(j) + 0.5f) * cell - 1.0f); };
  for (std::uint32_t j = 0; j < n_; ++j)
    for (std::uint32_t i = 0; i < n_; ++i) directions_[j * n_ + i] = square_to_sphere(centre(int(i), int(j)));
  neighbour_offsets_.reserve(count + 1);
  neighbour_offsets_.push_back(0);
  for (std::uint32_t j = 0; j < n_; ++j) {
    for (std::uint32_t i = 0; i < n_; ++i) {
      const std::uint32_t self = j * n_ + i;
      const std::size_t first = neighbour_cells_.size();
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          if (di == 0 && dj == 0) continue;
          const vec2 p = fold(centre(int(i) + di, int(j) + dj));
          const auto ci = std::uint32_t(std::clamp(int(std::floor((p.x + 1.0f) / cell)), 0, int(n_) - 1));
          const auto cj = std::uint32_t(std::clamp(int(std::floor((p.y + 1.0f) / cell)), 0, int(n_) - 1));
          const std::uint32_t other = cj * n_ + ci;
          if (other == self) continue;
          if (std::find(neighbour_cells_.begin() + std::ptrdiff_t(first), neighbour_cells_.end(), other) !=
              neighbour_cells_.end())
            continue;
          neighbour_cells_.push_back(other);
        }
      }
      neighbour_offsets_.push_back(std::uint32_t(neighbour_cells_.size()));
    }
  }
}

std::span<const std::uint32_t> DirectionGrid::neighbours(std::size_t cell) const {
  return std::span(neighbour_cells_).subspan(neighbour_offsets_[cell], neighbour_offsets_[cell + 1] - neighbour_offsets_[cell]);
}

std::size_t DirectionGrid::cell_of(const vec3& direction) const {
  const vec2 p = sphere_to_square(direction);
  const float cell = 2.0f / float(n_);
  const auto i = std::size_t(std::clamp(int(std::floor((p.x + 1.0f) / cell)), 0, int(n_) - 1));
  const auto j = std::size_t(std::clamp(int(std::floor((p.y + 1.0f) / cell)), 0, int(n_) - 1));
  return j * n_ + i;
}

DirectionGrid::Taps DirectionGrid::bilinear(const vec3& direction) const {
  const vec2 p = sphere_to_square(direction);
  const float cell = 2.0f / float(n_);
  // Continuous cell coordinates whose integers are cell centres.
  const float x = (p.x + 1.0f) / cell - 0.5f, y = (p.y + 1.0f) / cell - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  Taps taps;
  for (int t = 0; t < 4; ++t) {
    const int di = t & 1, dj = t >> 1;
    // The neighbour's centre, possibly past the edge, folded back into the square.
    const vec2 c = fold(vec2((fx + float(di) + 0.5f) * cell - 1.0f, (fy + float(dj) + 0.5f) * cell - 1.0f));
    const auto ci = std::uint32_t(std::clamp(int(std::floor((c.x + 1.0f) / cell)), 0, int(n_) - 1));
    const auto cj = std::uint32_t(std::clamp(int(std::floor((c.y + 1.0f) / cell)), 0, int(n_) - 1));
    taps.cells[std::size_t(t)] = cj * n_ + ci;
    taps.weights[std::size_t(t)] = (di ? tx : 1.0f - tx) * (dj ? ty : 1.0f - ty);
  }
  return taps;
}

float DirectionGrid::spacing() const { return std::sqrt(4.0f * pi) / float(n_); }

}  // namespace weft::ssdf
