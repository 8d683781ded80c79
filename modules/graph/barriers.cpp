// compile(), part 3: barriers. Walking the order, each resource's previous state is compared
// with the state a pass declares: any write on either side (RAW, WAR, WAW) or any change of
// state needs a barrier. Two reads in different states get one too even when the image
// layout is the same, because a later write's barrier names only the last state, and the
// earlier read is covered only through that chain. Equal read states need none.
module;
#include <cstdint>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;

namespace weft::detail {

namespace {
bool needs_barrier(gpu::Access before, gpu::Access after, bool texture) {
  // From Undefined a texture still needs its layout set; a buffer has nothing to wait for.
  if (before == gpu::Access::Undefined) return texture;
  return before != after || gpu::is_write(before) || gpu::is_write(after);
}
}  // namespace

void plan_barriers(const GraphData& graph, CompiledState& state) {
  const std::uint32_t R = state.resource_count;
  std::vector<gpu::Access>& current = state.scratch.current;
  std::vector<std::uint8_t>& released = state.scratch.released;  // a texture moves to its release state only once
  current.assign(R, gpu::Access::Undefined);
  released.assign(R, 0);
  for (std::uint32_t r = 0; r < R; ++r)
    if (graph.resources[r].imported) current[r] = graph.resources[r].initial_state;

  const auto positions = std::uint32_t(state.order.size());
  state.barriers.clear();
  state.barriers.reserve(graph.accesses.size() + 8);
  state.barrier_begin.assign(positions + 2, 0);
  for (std::uint32_t pos = 0; pos < positions; ++pos) {
    state.barrier_begin[pos] = std::uint32_t(state.barriers.size());
    const PassNode& pass = graph.passes[state.order[pos]];
    for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
      const AccessNode& a = graph.accesses[i];
      const std::uint32_t r = a.resource;
      const ResourceInfo& info = state.resources[r];
      const bool texture = info.type == ResourceType::Texture;
      if (!info.imported && pos == info.first_use) {
        const std::uint32_t first = state.takeover_first[r], last = first + state.takeover_count[r];
        if (first == last && texture) state.barriers.push_back(PlannedBarrier{r, gpu::Access::Undefined, a.access});
        for (std::uint32_t t = first; t < last; ++t) {
          const std::uint32_t occupant = state.takeovers[t];
          const gpu::Access occupant_after =
              texture && !released[occupant] ? release_state(current[occupant]) : current[occupant];
          state.barriers.push_back(
              PlannedBarrier{r, gpu::Access::Undefined, a.access, occupant, current[occupant], occupant_after});
          released[occupant] = 1;
          current[occupant] = occupant_after;
        }
      } else if (needs_barrier(current[r], a.access, texture)) {
        state.barriers.push_back(PlannedBarrier{r, current[r], a.access});
      }
      current[r] = a.access;
    }
  }
  state.barrier_begin[positions] = std::uint32_t(state.barriers.size());
  for (std::uint32_t r = 0; r < R; ++r) {
    const gpu::Access final_state = state.resource_final_state[r];
    if (final_state == gpu::Access::Undefined || !state.resources[r].used || current[r] == final_state) continue;
    state.barriers.push_back(PlannedBarrier{r, current[r], final_state});
  }
  state.barrier_begin[positions + 1] = std::uint32_t(state.barriers.size());
}

}  // namespace weft::detail
