// compile(), part 2: one walk over the execution order finds each resource's lifetime,
// places transient memory and derives the barriers. Transients whose lifetimes (first..last
// use) do not overlap share memory: each is placed at its first use into the best-fitting
// free run of its heap (or grows the heap) and freed after its last use, which the walk knows
// from scratch.last_pass. Each heap remembers, per byte range, its latest occupant, so a
// resource that takes over memory waits for its previous occupant's last access. Barriers:
// each resource's previous state is compared with the state a pass declares: any write on
// either side (RAW, WAR, WAW) or any change of state needs one. Two reads in different states
// get one too even when the image layout is the same, because a later write's barrier names
// only the last state, and the earlier read is covered only through that chain.
module;
#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;
import :compiled_state;

namespace weft::detail {

namespace {

constexpr std::uint64_t estimate_texture_alignment = 64 * 1024;
constexpr std::uint64_t estimate_buffer_alignment = 256;

constexpr std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) {
  if (alignment <= 1) return value;
  if ((alignment & (alignment - 1)) == 0) return (value + alignment - 1) & ~(alignment - 1);  // Vulkan's case
  return (value + alignment - 1) / alignment * alignment;
}

// A placement alignment, with whether it is a power of two (Vulkan's always are) decided
// once per distinct requirement rather than per free run tried.
struct Alignment {
  std::uint64_t value = 1;
  bool power_of_two = true;
  Alignment() = default;
  explicit Alignment(std::uint64_t alignment)
      : value(std::max<std::uint64_t>(alignment, 1)), power_of_two((value & (value - 1)) == 0) {}
  [[nodiscard]] std::uint64_t up(std::uint64_t x) const {
    return power_of_two ? (x + value - 1) & ~(value - 1) : (x + value - 1) / value * value;
  }
};

gpu::TextureDescriptor texture_descriptor(const ResourceInfo& r) {
  return gpu::TextureDescriptor{std::string(r.name), r.extent, r.format, r.texture_usage, r.mip_level_count,
                                r.dimension};
}

}  // namespace

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
  [[gnu::always_inline]] inline std::uint64_t place(std::uint64_t bytes, const Alignment& alignment, std::uint32_t resource,
                                                    bool& appended) {
    appended = false;
    if (free.empty() && bytes > 0) {
      const std::uint64_t at = alignment.up(size);
      if (at == size) {
        size = at + bytes;
        segments.push_back(Segment{at, size, resource});
        appended = true;
        return at;
      }
    }
    // One free run that fits exactly (a chain taking over what a resource two passes back
    // left): the best fit, taken whole, without setting up the search.
    if (free.size() == 1 && free[0].end - free[0].begin == bytes && alignment.up(free[0].begin) == free[0].begin) {
      const std::uint64_t at = free[0].begin;
      free.pop_back();
      return at;
    }
    constexpr std::uint64_t none = ~0ull;
    std::uint64_t best = none, best_size = none;
    std::size_t best_run = 0;
    for (std::size_t i = 0, n = free.size(); i < n; ++i) {
      const Range& f = free[i];
      const std::uint64_t at = alignment.up(f.begin);
      if (at + bytes <= f.end && f.end - f.begin < best_size) {
        best = at;
        best_size = f.end - f.begin;
        best_run = i;
      }
    }
    if (best == none) {
      const bool trailing = !free.empty() && free.back().end == size;
      best = alignment.up(trailing ? free.back().begin : size);
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

  [[gnu::always_inline]] inline void release(std::uint64_t offset, std::uint64_t bytes) {
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
  [[gnu::always_inline]] inline void occupy(std::uint64_t offset, std::uint64_t bytes, std::uint32_t resource, std::vector<std::uint32_t>& previous,
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

HeapBuilders::HeapBuilders() = default;
HeapBuilders::~HeapBuilders() = default;


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

namespace {

// Field by field in place (see next_version in graph.cppm: a barrier built on the stack and
// copied whole stalls store forwarding).
[[gnu::always_inline]] inline void add_barrier(std::vector<PlannedBarrier>& barriers, std::uint32_t resource,
                                               gpu::Access before, gpu::Access after,
                                               std::uint32_t previous_occupant = invalid_index,
                                               gpu::Access occupant_before = gpu::Access::Undefined,
                                               gpu::Access occupant_after = gpu::Access::Undefined) {
  PlannedBarrier& b = barriers.emplace_back();
  b.resource = resource;
  b.before = before;
  b.after = after;
  b.previous_occupant = previous_occupant;
  b.occupant_before = occupant_before;
  b.occupant_after = occupant_after;
}

// From Undefined a texture still needs its layout set; a buffer has nothing to wait for.
bool needs_barrier(gpu::Access before, gpu::Access after, bool texture) {
  if (before == gpu::Access::Undefined) return texture;
  return before != after || gpu::is_write(before) || gpu::is_write(after);
}

// Sizes transients: estimated (repeated descriptors estimated once in a row), by the
// caller's functions, or by the device.
class Sizer {
 public:
  Sizer(const CompileOptions& options, const gpu::Device* device)
      : options_(options), device_(device), estimating_(device == nullptr && !options.texture_requirements) {}

  // The requirements of `info`, or false with `error` set. Estimates (the common case of
  // compiling without a device) need no Result and are repeated in a row for equal textures.
  [[gnu::always_inline]] bool size(const ResourceInfo& info, gpu::MemoryRequirements& out, Alignment& alignment,
                                   Error& error) {
    const bool texture = info.type == ResourceType::Texture;
    if (estimating_ && texture) {
      if (!have_last_ || info.extent.width != last_.extent.width || info.extent.height != last_.extent.height ||
          info.extent.depth_or_layers != last_.extent.depth_or_layers || info.format != last_.format ||
          info.mip_level_count != last_.mip_level_count || info.dimension != last_.dimension) [[unlikely]] {
        last_.extent = info.extent;
        last_.format = info.format;
        last_.mip_level_count = info.mip_level_count;
        last_.dimension = info.dimension;
        last_requirements_ = estimate_requirements(info);
        last_alignment_ = Alignment(last_requirements_.alignment);
        have_last_ = true;
      }
      out = last_requirements_;
      alignment = last_alignment_;
      return true;
    }
    Result<gpu::MemoryRequirements> req = query(info);
    if (!req) {
      error = std::move(req.error());
      return false;
    }
    out = *req;
    alignment = Alignment(req->alignment);
    return true;
  }

 private:
  Result<gpu::MemoryRequirements> query(const ResourceInfo& info) const {
    const bool texture = info.type == ResourceType::Texture;
    const bool custom = texture ? bool(options_.texture_requirements) : bool(options_.buffer_requirements);
    if (device_ == nullptr && !custom) return estimate_requirements(info);
    if (!texture) {
      const gpu::BufferDescriptor desc{std::string(info.name), info.buffer_size, info.buffer_usage};
      return device_ != nullptr ? device_->memory_requirements(desc) : options_.buffer_requirements(desc);
    }
    return device_ != nullptr ? device_->memory_requirements(texture_descriptor(info))
                              : options_.texture_requirements(texture_descriptor(info));
  }

 private:
  const CompileOptions& options_;
  const gpu::Device* device_;
  bool estimating_;  // textures are estimated (no device, no custom function)
  ResourceInfo last_;  // the texture last_requirements_ was estimated for
  gpu::MemoryRequirements last_requirements_{};
  Alignment last_alignment_;
  bool have_last_ = false;
};

// Aliasing groups: resources connected by takeovers, numbered in the order of their
// lowest-index members. A resource being placed joins the group of the memory it takes over
// (one store); only a resource taking over memory of two groups merges them, through a
// union-find over group ids, which most frames never walk.
class AliasGroups {
 public:
  explicit AliasGroups(CompileScratch& scratch)
      : group_(scratch.alias_group_of), parent_(scratch.alias_group_parent) {}
  // `r` (being placed) takes over memory `occupant` used.
  void link(std::uint32_t r, std::uint32_t occupant, std::uint32_t resource_count) {
    if (!ready_) {  // a frame without takeovers never fills these
      group_.assign(resource_count, invalid_index);
      parent_.clear();
      ready_ = true;
    }
    std::uint32_t theirs = group_[occupant];
    if (theirs == invalid_index) {
      theirs = group_[occupant] = std::uint32_t(parent_.size());
      parent_.push_back(theirs);
    }
    const std::uint32_t mine = group_[r];
    if (mine == invalid_index) {
      group_[r] = theirs;
      return;
    }
    const std::uint32_t x = root(mine), y = root(theirs);
    parent_[std::max(x, y)] = std::min(x, y);
  }
  void number(std::span<ResourceInfo> resources, std::vector<std::uint32_t>& number_of_root) {
    if (!ready_) return;
    number_of_root.assign(parent_.size(), invalid_index);
    std::uint32_t groups = 0;
    for (std::uint32_t r = 0; r < resources.size(); ++r) {
      if (group_[r] == invalid_index) continue;
      const std::uint32_t top = root(group_[r]);
      if (number_of_root[top] == invalid_index) number_of_root[top] = groups++;
      resources[r].alias_group = number_of_root[top];
    }
  }

 private:
  std::uint32_t root(std::uint32_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  std::vector<std::uint32_t>& group_;   // per resource: its group id, or invalid_index
  std::vector<std::uint32_t>& parent_;  // per group id: union-find parent
  bool ready_ = false;
};

}  // namespace

void plan_frame(const GraphData& graph, CompiledState& state, const gpu::Device* device, bool replan,
                std::vector<GraphError>& errors) {
  const std::uint32_t R = state.resource_count;
  const auto positions = std::uint32_t(state.order.size());
  CompileScratch& scratch = state.scratch;
  std::vector<std::uint32_t>& last_pass = scratch.last_pass;
  std::vector<gpu::Access>& current = scratch.current;
  std::vector<ResourceInfo>& resources = state.resources;
  if (replan) {
    // The order and lifetimes are known; start the walk afresh from them.
    last_pass.assign(R, invalid_index);
    for (std::uint32_t r = 0; r < R; ++r) {
      ResourceInfo& info = resources[r];
      if (info.used) last_pass[r] = state.order[info.last_use];
      info.used = false;
      info.first_use = info.last_use = invalid_index;
      info.heap = invalid_index;
      info.offset = info.bytes = 0;
      info.alias_group = invalid_index;
      current[r] = graph.resources[r].imported ? graph.resources[r].initial_state : gpu::Access::Undefined;
    }
  }
  scratch.released.assign(R, 0);  // a texture moves to its release state only once
  state.takeover_first.assign(R, 0);
  state.takeover_count.assign(R, 0);
  state.takeovers.clear();
  state.barriers.clear();
  state.barriers.reserve(graph.accesses.size() + 8);
  state.barrier_begin.assign(positions + 2, 0);

  MemoryPlan plan;
  plan.heaps = std::move(state.memory.heaps);  // its capacity, from an earlier compile
  plan.heaps.clear();
  plan.from_device = device != nullptr;
  std::vector<HeapBuilder>& heaps = scratch.heaps.heaps;
  std::size_t heap_count = 0;  // heaps[heap_count..] are kept only for their arrays' capacity
  Sizer sizer(state.options, device);
  AliasGroups groups(scratch);
  const bool aliasing = state.options.aliasing;

  // Raw pointers: the arrays keep their sizes during the walk, and the compiler cannot
  // otherwise keep their addresses in registers across the stores below.
  ResourceInfo* const info_of = resources.data();
  gpu::Access* const state_of = current.data();
  const std::uint32_t* const last_pass_of = last_pass.data();
  std::uint32_t* const takeover_first = state.takeover_first.data();
  std::uint32_t* const takeover_count = state.takeover_count.data();
  std::uint8_t* const released = scratch.released.data();
  const AccessNode* const accesses = graph.accesses.data();
  std::vector<std::uint32_t>& takeovers = state.takeovers;
  std::vector<PlannedBarrier>& barriers = state.barriers;

  Error size_error;
  constexpr std::size_t none = ~std::size_t(0);
  std::size_t heaps_of_type[2] = {0, 0}, only_heap[2] = {none, none};  // per ResourceType

  // Places one transient at its first use; its takeovers become barriers right after.
  auto place = [&](std::uint32_t r) {
    ResourceInfo& info = info_of[r];
    gpu::MemoryRequirements requirements;
    Alignment alignment;
    if (!sizer.size(info, requirements, alignment, size_error)) [[unlikely]] {
      info.bytes = 0;
      errors.push_back(GraphError{GraphErrorKind::Memory,
                                  weft::format("{}: cannot size its memory: {}", graph.describe(r), size_error.message),
                                  {}, {std::string(info.name)}});
      return;
    }
    const gpu::MemoryRequirements* const req = &requirements;
    info.bytes = req->size;
    plan.unaliased_bytes += req->size;
    // The first heap that can take it: when there is one heap of this type, that one.
    const auto type = std::size_t(info.type);
    std::size_t heap = only_heap[type];
    if (heap == none || (heaps[heap].type_bits & req->type_bits) == 0) {
      heap = 0;
      while (heap < heap_count && !(heaps[heap].type == info.type && (heaps[heap].type_bits & req->type_bits) != 0))
        ++heap;
    }
    if (heap == heap_count) {
      if (heap == heaps.size()) heaps.emplace_back();
      HeapBuilder& fresh = heaps[heap];
      fresh.type = info.type;
      fresh.type_bits = req->type_bits;
      fresh.size = 0;
      fresh.free.clear();
      fresh.segments.clear();
      ++heap_count;
      only_heap[type] = ++heaps_of_type[type] == 1 ? heap : none;
    }
    HeapBuilder& h = heaps[heap];
    h.type_bits &= req->type_bits;
    bool appended = false;
    const std::uint64_t offset = h.place(req->size, alignment, r, appended);
    const auto first_takeover = std::uint32_t(takeovers.size());
    if (!appended) h.occupy(offset, req->size, r, takeovers, first_takeover);
    info.heap = std::uint32_t(heap);
    info.offset = offset;
    const auto count = std::uint32_t(takeovers.size()) - first_takeover;
    takeover_first[r] = first_takeover;
    takeover_count[r] = count;
    for (std::uint32_t i = 0; i < count; ++i) groups.link(r, takeovers[first_takeover + i], R);
  };

  // Transients whose last use is the current pass: freed once the whole pass is placed, so
  // that nothing the pass uses shares memory with anything else it uses.
  std::vector<std::uint32_t>& ending = scratch.stack;
  for (std::uint32_t pos = 0; pos < positions; ++pos) {
    const std::uint32_t p = state.order[pos];
    state.passes[p].order_position = pos;
    const PassNode& pass = graph.passes[p];
    const AccessNode* const end = accesses + pass.first_access + pass.access_count;
    state.barrier_begin[pos] = std::uint32_t(barriers.size());
    ending.clear();
    for (const AccessNode* a = accesses + pass.first_access; a != end; ++a) {
      const std::uint32_t r = a->resource;
      ResourceInfo& info = info_of[r];
      const gpu::Access before = state_of[r];
      if (!info.used && !a->imported) {
        // First use of a transient (in the order the pass declared them): place it, then
        // wait for the previous occupants of its memory, or just set its layout.
        info.used = true;
        info.first_use = pos;
        place(r);
        const std::uint32_t first = takeover_first[r], last = first + takeover_count[r];
        if (first == last && a->texture) add_barrier(barriers, r, gpu::Access::Undefined, a->access);
        for (std::uint32_t t = first; t < last; ++t) {
          const std::uint32_t occupant = takeovers[t];
          const gpu::Access occupant_before = state_of[occupant];
          const gpu::Access occupant_after =
              a->texture && !released[occupant] ? release_state(occupant_before) : occupant_before;
          add_barrier(barriers, r, gpu::Access::Undefined, a->access, occupant, occupant_before, occupant_after);
          released[occupant] = 1;
          state_of[occupant] = occupant_after;
        }
      } else {
        if (!info.used) {
          info.used = true;
          info.first_use = pos;
        }
        if (needs_barrier(before, a->access, a->texture)) add_barrier(barriers, r, before, a->access);
      }
      info.last_use = pos;
      state_of[r] = a->access;
      if (last_pass_of[r] == p) ending.push_back(r);
    }
    if (aliasing)
      for (const std::uint32_t r : ending)
        if (info_of[r].heap != invalid_index) heaps[info_of[r].heap].release(info_of[r].offset, info_of[r].bytes);
  }
  state.barrier_begin[positions] = std::uint32_t(state.barriers.size());

  // Outputs are read after the frame: their lifetimes run to the end.
  for (const OutputNode& out : graph.outputs)
    if (out.resource < R && resources[out.resource].used) resources[out.resource].last_use = positions - 1;
  for (std::uint32_t r = 0; r < R; ++r) {
    const gpu::Access final_state = state.resource_final_state[r];
    if (final_state == gpu::Access::Undefined || !resources[r].used || current[r] == final_state) continue;
    add_barrier(state.barriers, r, current[r], final_state);
  }
  state.barrier_begin[positions + 1] = std::uint32_t(state.barriers.size());

  groups.number(resources, scratch.alias_group_number);
  for (std::size_t h = 0; h < heap_count; ++h) {
    plan.heaps.push_back(MemoryHeap{heaps[h].type, heaps[h].type_bits, heaps[h].size});
    plan.aliased_bytes += heaps[h].size;
  }
  state.memory = std::move(plan);
}
}  // namespace weft::detail
