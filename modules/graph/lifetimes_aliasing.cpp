// compile(), part 2: transient memory. Transients whose lifetimes (first..last use in the
// execution order) do not overlap share memory. A sweep over the order places each resource
// at its first use into the best-fitting free run of its heap (or grows the heap) and frees
// it after its last use. Each heap remembers, per byte range, its latest occupant, so the
// barrier planner knows whose last access a resource must wait for when it takes over memory.
module;
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;

namespace weft::detail {

namespace {

constexpr std::uint64_t estimate_texture_alignment = 64 * 1024;
constexpr std::uint64_t estimate_buffer_alignment = 256;

constexpr std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) {
  if (alignment <= 1) return value;
  if ((alignment & (alignment - 1)) == 0) return (value + alignment - 1) & ~(alignment - 1);  // Vulkan's case
  return (value + alignment - 1) / alignment * alignment;
}

gpu::TextureDescriptor texture_descriptor(const ResourceInfo& r) {
  return gpu::TextureDescriptor{std::string(r.name), r.extent, r.format, r.texture_usage, r.mip_level_count,
                                r.dimension};
}

struct Range {
  std::uint64_t begin, end;
};

// Who used each byte range of a heap last: consecutive segments covering [0, size).
struct Segment {
  std::uint64_t begin, end;
  std::uint32_t occupant;  // invalid_index: never used
};

struct HeapBuilder {
  ResourceType type;
  std::uint32_t type_bits;
  std::uint64_t size = 0;
  std::vector<Range> free;  // dead memory inside [0, size): sorted, coalesced
  std::vector<Segment> segments;

  // Best fit among the free runs, else at the end of the heap (growing it, starting inside
  // the trailing free run when there is one). The common cases of a frame -- nothing free (a
  // new slot at the end) and a free run that fits exactly (a chain reusing the memory of a
  // resource two passes back) -- touch only the ends of the arrays; every case places where
  // the general best-fit search would.
  // Returns the offset; `appended` is set when the resource got a fresh slot at the end of
  // the heap with no padding, whose segment place() has already recorded (occupy() not needed).
  std::uint64_t place(std::uint64_t bytes, std::uint64_t alignment, std::uint32_t resource, bool& appended) {
    appended = false;
    if (free.empty() && bytes > 0) {
      const std::uint64_t at = align_up(size, alignment);
      if (at == size) {
        size = at + bytes;
        segments.push_back(Segment{at, size, resource});
        appended = true;
        return at;
      }
    }
    constexpr std::uint64_t none = ~0ull;
    std::uint64_t best = none, best_size = none;
    std::size_t best_run = 0;
    for (std::size_t i = 0, n = free.size(); i < n; ++i) {
      const Range& f = free[i];
      const std::uint64_t at = align_up(f.begin, alignment);
      if (at + bytes <= f.end && f.end - f.begin < best_size) {
        best = at;
        best_size = f.end - f.begin;
        best_run = i;
      }
    }
    if (best == none) {
      const bool trailing = !free.empty() && free.back().end == size;
      best = align_up(trailing ? free.back().begin : size, alignment);
      const std::uint64_t grown = best + bytes;
      if (trailing) free.back().end = grown;
      else free.push_back(Range{size, grown});
      segments.push_back(Segment{size, grown, invalid_index});
      size = grown;
      best_run = free.size() - 1;
    }
    // Carve [best, best + bytes) out of the free run holding it.
    const auto run = free.begin() + std::ptrdiff_t(best_run);
    const Range whole = *run;
    const Range left{whole.begin, best}, right{best + bytes, whole.end};
    if (left.end > left.begin && right.end > right.begin) {
      *run = left;
      free.insert(run + 1, right);
    } else if (left.end > left.begin) {
      *run = left;
    } else if (right.end > right.begin) {
      *run = right;
    } else if (best_run + 1 == free.size()) {
      free.pop_back();
    } else {
      free.erase(run);
    }
    return best;
  }

  void release(std::uint64_t offset, std::uint64_t bytes) {
    Range r{offset, offset + bytes};
    // Past every free run (or none): join the last one or append, no search.
    if (free.empty() || free.back().end <= r.begin) {
      if (!free.empty() && free.back().end == r.begin) free.back().end = r.end;
      else free.push_back(r);
      return;
    }
    auto at = std::upper_bound(free.begin(), free.end(), offset, [](std::uint64_t x, const Range& f) { return x < f.begin; });
    const bool join_previous = at != free.begin() && (at - 1)->end == r.begin;
    const bool join_next = at != free.end() && at->begin == r.end;
    if (join_previous && join_next) {
      (at - 1)->end = at->end;
      free.erase(at);
    } else if (join_previous) {
      (at - 1)->end = r.end;
    } else if (join_next) {
      at->begin = r.begin;
    } else {
      free.insert(at, r);
    }
  }

  // Marks [offset, offset + bytes) as `resource`'s and appends the previous occupants to
  // `previous` (each once: `previous` holds only this resource's).
  void occupy(std::uint64_t offset, std::uint64_t bytes, std::uint32_t resource, std::vector<std::uint32_t>& previous,
              std::size_t previous_begin) {
    const std::uint64_t end = offset + bytes;
    auto first = std::partition_point(segments.begin(), segments.end(), [&](const Segment& s) { return s.end <= offset; });
    if (bytes > 0 && first != segments.end() && first->begin == offset && first->end == end) {  // exactly one earlier occupant
      if (first->occupant != invalid_index) previous.push_back(first->occupant);
      first->occupant = resource;
      return;
    }
    auto last = first;
    for (; last != segments.end() && last->begin < end; ++last)
      if (last->occupant != invalid_index &&
          std::find(previous.begin() + std::ptrdiff_t(previous_begin), previous.end(), last->occupant) == previous.end())
        previous.push_back(last->occupant);
    Segment replacement[3];
    std::size_t n = 0;
    if (first != last && first->begin < offset) replacement[n++] = Segment{first->begin, offset, first->occupant};
    replacement[n++] = Segment{offset, end, resource};
    if (first != last && (last - 1)->end > end) replacement[n++] = Segment{end, (last - 1)->end, (last - 1)->occupant};
    const auto at = first - segments.begin();
    const auto removed = last - first;
    // Overwrite in place where possible: erase + insert would move the tail twice.
    if (std::ptrdiff_t(n) <= removed) {
      std::copy(replacement, replacement + n, first);
      segments.erase(first + std::ptrdiff_t(n), last);
    } else {
      std::copy(replacement, replacement + removed, first);
      segments.insert(segments.begin() + at + removed, replacement + removed, replacement + n);
    }
  }
};

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace

gpu::MemoryRequirements estimate_requirements(const ResourceInfo& r) {
  if (r.type == ResourceType::Buffer)
    return {align_up(std::max<std::uint64_t>(r.buffer_size, 1), estimate_buffer_alignment), estimate_buffer_alignment,
            ~0u};
  const std::uint64_t texel = std::max<std::uint32_t>(gpu::format_info(r.format).bytes_per_texel, 1);
  std::uint64_t bytes = 0;
  std::uint64_t w = r.extent.width, h = r.extent.height;
  const std::uint64_t layers = std::max(1u, r.extent.depth_or_layers) * (r.dimension == gpu::TextureDimension::Cube ? 6 : 1);
  for (std::uint32_t m = 0; m < std::max(1u, r.mip_level_count); ++m) {
    bytes += w * h * layers * texel;
    w = std::max<std::uint64_t>(1, w / 2);
    h = std::max<std::uint64_t>(1, h / 2);
  }
  return {align_up(bytes, estimate_texture_alignment), estimate_texture_alignment, ~0u};
}

void plan_memory(const GraphData& graph, CompiledState& state, const gpu::Device* device,
                 std::vector<GraphError>& errors) {
  const std::uint32_t R = state.resource_count;
  const auto positions = std::uint32_t(state.order.size());
  MemoryPlan plan;
  plan.heaps = std::move(state.memory.heaps);  // its capacity, from an earlier compile
  plan.heaps.clear();
  plan.from_device = device != nullptr;

  // Requirements, and the transients bucketed by first and last use (linked lists, no sort).
  CompileScratch& scratch = state.scratch;
  std::vector<gpu::MemoryRequirements>& requirements = scratch.requirements;
  requirements.assign(R, gpu::MemoryRequirements{});
  std::vector<std::uint32_t>& start_head = scratch.start_head;
  std::vector<std::uint32_t>& end_head = scratch.end_head;
  std::vector<std::uint32_t>& start_next = scratch.start_next;
  std::vector<std::uint32_t>& end_next = scratch.end_next;
  start_head.assign(positions, invalid_index);
  end_head.assign(positions, invalid_index);
  start_next.assign(R, invalid_index);
  end_next.assign(R, invalid_index);
  ResourceInfo last;  // the texture last_requirements was estimated for
  gpu::MemoryRequirements last_requirements{};
  bool have_last = false;
  for (std::uint32_t r = R; r-- > 0;) {
    ResourceInfo& info = state.resources[r];
    info.heap = invalid_index;
    info.offset = 0;
    info.bytes = 0;
    info.alias_group = invalid_index;
    if (info.imported || !info.used) continue;
    const bool custom = info.type == ResourceType::Texture ? bool(state.options.texture_requirements)
                                                           : bool(state.options.buffer_requirements);
    if (device == nullptr && !custom) {
      // Frames repeat descriptors (a chain of full-screen targets): estimate each once in a row.
      if (info.type == ResourceType::Texture) {
        if (!have_last || info.extent.width != last.extent.width || info.extent.height != last.extent.height ||
            info.extent.depth_or_layers != last.extent.depth_or_layers || info.format != last.format ||
            info.mip_level_count != last.mip_level_count || info.dimension != last.dimension) {
          last = info;
          last_requirements = estimate_requirements(info);
          have_last = true;
        }
        requirements[r] = last_requirements;
      } else {
        requirements[r] = estimate_requirements(info);
      }
    } else {
      const gpu::BufferDescriptor buffer_desc{std::string(info.name), info.buffer_size, info.buffer_usage};
      Result<gpu::MemoryRequirements> req =
          device != nullptr ? (info.type == ResourceType::Texture ? device->memory_requirements(texture_descriptor(info))
                                                                  : device->memory_requirements(buffer_desc))
                            : (info.type == ResourceType::Texture ? state.options.texture_requirements(texture_descriptor(info))
                                                                  : state.options.buffer_requirements(buffer_desc));
      if (!req) {
        errors.push_back(GraphError{GraphErrorKind::Memory,
                                    weft::format("{}: cannot size its memory: {}", graph.describe(r), req.error().message),
                                    {}, {std::string(info.name)}});
        continue;
      }
      requirements[r] = *req;
    }
    info.bytes = requirements[r].size;
    plan.unaliased_bytes += requirements[r].size;
    start_next[r] = start_head[info.first_use];
    start_head[info.first_use] = r;
    end_next[r] = end_head[info.last_use];
    end_head[info.last_use] = r;
  }

  // Aliasing groups: resources connected by takeovers, numbered by their lowest index. Every
  // union makes the lower root the parent, so a group's root is its lowest index, and a
  // resource is in a group of two or more exactly when it took over or was taken over. The
  // unions happen as the takeovers are found.
  std::vector<std::uint32_t>& parent = scratch.parent;
  std::vector<std::uint32_t>& linked = scratch.members;
  parent.resize(R);
  std::iota(parent.begin(), parent.end(), 0u);
  linked.assign(R, 0);

  std::vector<HeapBuilder> heaps;
  state.takeover_first.assign(R, 0);
  state.takeover_count.assign(R, 0);
  state.takeovers.clear();
  for (std::uint32_t pos = 0; pos < positions; ++pos) {
    for (std::uint32_t r = start_head[pos]; r != invalid_index; r = start_next[r]) {
      ResourceInfo& info = state.resources[r];
      const gpu::MemoryRequirements& req = requirements[r];
      std::uint32_t heap = 0;
      while (heap < heaps.size() && !(heaps[heap].type == info.type && (heaps[heap].type_bits & req.type_bits) != 0))
        ++heap;
      if (heap == heaps.size()) heaps.push_back(HeapBuilder{info.type, req.type_bits});
      HeapBuilder& h = heaps[heap];
      h.type_bits &= req.type_bits;
      bool appended = false;
      const std::uint64_t offset = h.place(req.size, std::max<std::uint64_t>(req.alignment, 1), r, appended);
      const auto first_takeover = std::uint32_t(state.takeovers.size());
      if (!appended) h.occupy(offset, req.size, r, state.takeovers, first_takeover);
      info.heap = heap;
      info.offset = offset;
      state.takeover_first[r] = first_takeover;
      state.takeover_count[r] = std::uint32_t(state.takeovers.size()) - first_takeover;
      for (std::uint32_t i = first_takeover, end = std::uint32_t(state.takeovers.size()); i < end; ++i) {
        const std::uint32_t a = find_root(parent, r), b = find_root(parent, state.takeovers[i]);
        parent[std::max(a, b)] = std::min(a, b);
        linked[r] = linked[state.takeovers[i]] = 1;
      }
    }
    if (!state.options.aliasing) continue;
    for (std::uint32_t r = end_head[pos]; r != invalid_index; r = end_next[r])
      if (state.resources[r].heap != invalid_index)
        heaps[state.resources[r].heap].release(state.resources[r].offset, requirements[r].size);
  }

  if (!state.takeovers.empty()) {
    std::vector<std::uint32_t>& group_of_root = scratch.group_of_root;
    group_of_root.assign(R, invalid_index);
    std::uint32_t groups = 0;
    for (std::uint32_t r = 0; r < R; ++r) {
      if (!linked[r]) continue;
      const std::uint32_t root = find_root(parent, r);
      if (group_of_root[root] == invalid_index) group_of_root[root] = groups++;
      state.resources[r].alias_group = group_of_root[root];
    }
  }

  for (const HeapBuilder& h : heaps) {
    plan.heaps.push_back(MemoryHeap{h.type, h.type_bits, h.size});
    plan.aliased_bytes += h.size;
  }
  state.memory = std::move(plan);
}

}  // namespace weft::detail
