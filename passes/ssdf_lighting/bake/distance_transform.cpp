// The signed spherical distance transform: a Dijkstra-ordered propagation of nearest
// opposite-kind samples (fast) and the all-pairs reference. Distances are compared as dot
// products (larger = nearer) and turned into angles once at the end.
module;
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <queue>
#include <span>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;

namespace weft::ssdf {
namespace {
constexpr std::uint32_t kNoSite = 0xffffffffu;

float signed_angle(bool visible, float dot) {
  const float angle = std::acos(std::clamp(dot, -1.0f, 1.0f));
  return visible ? angle : -angle;
}
}  // namespace

void signed_distance(const DirectionGrid& grid, std::span<const std::uint8_t> visible, std::span<float> out) {
  const std::size_t count = grid.size();
  std::vector<std::uint32_t> site(count, kNoSite);
  std::vector<float> best(count, -2.0f);
  using Entry = std::pair<float, std::uint32_t>;  // (dot with the cell's site, cell): max-heap
  std::priority_queue<Entry> queue;
  // Seeds: cells next to a cell of the other kind take it as their site.
  for (std::size_t c = 0; c < count; ++c) {
    for (std::uint32_t nb : grid.neighbours(c)) {
      if (visible[nb] == visible[c]) continue;
      const float dot = glm::dot(grid.direction(c), grid.direction(nb));
      if (dot > best[c]) best[c] = dot, site[c] = nb;
    }
    if (site[c] != kNoSite) queue.emplace(best[c], std::uint32_t(c));
  }
  // Nearest first: a cell's site is offered to its same-kind neighbours, who keep it when it
  // is truly nearer than theirs.
  while (!queue.empty()) {
    const auto [dot, c] = queue.top();
    queue.pop();
    if (dot < best[c]) continue;  // stale entry
    const vec3& s = grid.direction(site[c]);
    for (std::uint32_t nb : grid.neighbours(c)) {
      if (visible[nb] != visible[c]) continue;
      const float candidate = glm::dot(grid.direction(nb), s);
      if (candidate > best[nb]) {
        best[nb] = candidate;
        site[nb] = site[c];
        queue.emplace(candidate, nb);
      }
    }
  }
  // One sweep over every neighbour's site catches most cells whose nearest sample arrived
  // by a path the ordered propagation did not take (Voronoi regions that are not connected
  // on the grid).
  for (std::size_t c = 0; c < count; ++c)
    for (std::uint32_t nb : grid.neighbours(c)) {
      if (visible[nb] != visible[c] || site[nb] == kNoSite) continue;
      const float candidate = glm::dot(grid.direction(c), grid.direction(site[nb]));
      if (candidate > best[c]) best[c] = candidate, site[c] = site[nb];
    }
  for (std::size_t c = 0; c < count; ++c)
    out[c] = site[c] == kNoSite ? (visible[c] ? pi : -pi) : signed_angle(visible[c] != 0, best[c]);
}

void signed_distance_exact(const DirectionGrid& grid, std::span<const std::uint8_t> visible, std::span<float> out) {
  const std::size_t count = grid.size();
  for (std::size_t c = 0; c < count; ++c) {
    float best = -2.0f;
    for (std::size_t o = 0; o < count; ++o)
      if (visible[o] != visible[c]) best = std::max(best, glm::dot(grid.direction(c), grid.direction(o)));
    out[c] = best < -1.5f ? (visible[c] ? pi : -pi) : signed_angle(visible[c] != 0, best);
  }
}

cluster::Matrix signed_distances(const DirectionGrid& grid, const Visibility& visibility, std::size_t threads,
                                 bool exact, bool progress) {
  cluster::Matrix out(visibility.probe_count, visibility.directions);
  std::atomic<std::size_t> done{0};
  const auto start = std::chrono::steady_clock::now();
  const std::size_t report_every = std::max<std::size_t>(1, visibility.probe_count / 10);
  cluster::parallel_for(visibility.probe_count, threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      if (exact)
        signed_distance_exact(grid, visibility.of(p), out.row(p));
      else
        signed_distance(grid, visibility.of(p), out.row(p));
      const std::size_t finished = ++done;
      if (progress && visibility.probe_count >= 1000 && finished % report_every == 0)
        log::info(weft::format("SSDF distance transform: {}/{} vertices, {:.1f} s", finished, visibility.probe_count,
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
    }
  });
  return out;
}

}  // namespace weft::ssdf
