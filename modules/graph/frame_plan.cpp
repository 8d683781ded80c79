// compile(), part 2: one walk over the execution order finds each resource's lifetime,
// places transient memory and derives the barriers. Transients whose lifetimes (first..last
// use) do not overlap share memory: each is placed at its first use into the best-fitting
// free run of its heap (or grows the heap) and freed after its last use, which the walk knows
// from scratch.last_pass. Each heap remembers, per byte range, its latest occupant, so a
// resource that takes over memory waits for its previous occupant's last access; with many
// transients alive its free runs and byte ranges move from sorted arrays to search trees, so
// a placement costs O(log n) however many there are (see HeapBuilder). Barriers:
// each resource's previous state is compared with the state a pass declares: any write on
// either side (RAW, WAR, WAW) or any change of state needs one. Two reads in different states
// get one too even when the image layout is the same, because a later write's barrier names
// only the last state, and the earlier read is covered only through that chain.
module;
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <type_traits>
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
                                r.dimension, r.sample_count};
}

}  // namespace

// ---- the memory planner's structures ------------------------------------------------------
// A heap keeps its free runs (dead memory, coalesced) and its segments (who used each byte
// range last, covering the heap). While there are few, both are sorted arrays: a scan and a
// shift of a few entries cost least, and a frame's common cases touch only their ends. Once
// there are many (many transients alive, a fragmented heap), both become search trees and
// the free runs gain an index by size, so a placement costs O(log n) -- a binary search, not
// a walk over every free run, and no shifting of long arrays. The placement is the same
// either way: plain best fit (the smallest free run that fits, the lowest of equal ones).

// Tree nodes, recycled: the trees are emptied every compile, and a compile of the same shape
// allocates none. Every node of one pool has one size (one tree's node type).
class NodePool {
 public:
  NodePool() = default;
  NodePool(const NodePool&) = delete;
  NodePool& operator=(const NodePool&) = delete;
  void* get(std::size_t bytes) {
    if (free_ != nullptr) {
      void* p = free_;
      free_ = *static_cast<void**>(p);
      return p;
    }
    bytes = (bytes + 15) & ~std::size_t(15);
    if (left_ < bytes) {
      const std::size_t block = std::max<std::size_t>(bytes * 64, 4096);
      blocks_.push_back(std::make_unique_for_overwrite<std::byte[]>(block));
      cursor_ = blocks_.back().get();
      left_ = block;
    }
    void* p = cursor_;
    cursor_ += bytes;
    left_ -= bytes;
    return p;
  }
  void put(void* p) {
    *static_cast<void**>(p) = free_;
    free_ = p;
  }

 private:
  std::vector<std::unique_ptr<std::byte[]>> blocks_;
  std::byte* cursor_ = nullptr;
  std::size_t left_ = 0;
  void* free_ = nullptr;
};

template <class T>
struct PoolAllocator {
  using value_type = T;
  NodePool* pool;
  explicit PoolAllocator(NodePool* p) : pool(p) {}
  template <class U>
  PoolAllocator(const PoolAllocator<U>& other) : pool(other.pool) {}  // NOLINT: rebinding, as allocators do
  T* allocate(std::size_t n) { return static_cast<T*>(pool->get(n * sizeof(T))); }
  void deallocate(T* p, std::size_t) { pool->put(p); }
  friend bool operator==(const PoolAllocator& a, const PoolAllocator& b) { return a.pool == b.pool; }
};

template <class Key, class Value>
using PooledMap = std::map<Key, Value, std::less<>, PoolAllocator<std::pair<const Key, Value>>>;

struct Range {
  std::uint64_t begin, end;
};

// Free runs in a sorted array and in a tree, behind the same few operations.
struct RunArray {
  std::vector<Range> runs;
  using iterator = std::vector<Range>::iterator;
  static std::uint64_t begin_of(iterator i) { return i->begin; }
  static std::uint64_t end_of(iterator i) { return i->end; }
  static void set_end(iterator i, std::uint64_t end) { i->end = end; }
  iterator begin() { return runs.begin(); }
  iterator end() { return runs.end(); }
  [[nodiscard]] std::size_t size() const { return runs.size(); }
  [[nodiscard]] bool empty() const { return runs.empty(); }
  // The ends first: a frame's common cases append and take the last run.
  iterator insert(iterator at, std::uint64_t begin, std::uint64_t end) {
    if (at == runs.end()) {
      runs.push_back(Range{begin, end});
      return runs.end() - 1;
    }
    return runs.insert(at, Range{begin, end});
  }
  iterator erase(iterator i) {
    if (i + 1 == runs.end()) {
      runs.pop_back();
      return runs.end();
    }
    return runs.erase(i);
  }
  iterator move_begin(iterator i, std::uint64_t begin) {
    i->begin = begin;
    return i;
  }
  iterator upper_bound(std::uint64_t begin) {
    return std::upper_bound(runs.begin(), runs.end(), begin, [](std::uint64_t x, const Range& f) { return x < f.begin; });
  }
  iterator find(std::uint64_t begin) {
    return std::partition_point(runs.begin(), runs.end(), [&](const Range& f) { return f.begin < begin; });
  }
};

struct RunTree {
  explicit RunTree(NodePool* pool) : runs(PooledMap<std::uint64_t, std::uint64_t>::allocator_type(pool)) {}
  PooledMap<std::uint64_t, std::uint64_t> runs;  // first byte -> one past the last
  using iterator = PooledMap<std::uint64_t, std::uint64_t>::iterator;
  static std::uint64_t begin_of(iterator i) { return i->first; }
  static std::uint64_t end_of(iterator i) { return i->second; }
  static void set_end(iterator i, std::uint64_t end) { i->second = end; }
  iterator begin() { return runs.begin(); }
  iterator end() { return runs.end(); }
  [[nodiscard]] std::size_t size() const { return runs.size(); }
  [[nodiscard]] bool empty() const { return runs.empty(); }
  iterator insert(iterator at, std::uint64_t begin, std::uint64_t end) { return runs.emplace_hint(at, begin, end); }
  iterator erase(iterator i) { return runs.erase(i); }
  iterator move_begin(iterator i, std::uint64_t begin) {  // a key changes: out and in again
    const std::uint64_t end = i->second;
    return runs.emplace_hint(runs.erase(i), begin, end);
  }
  iterator upper_bound(std::uint64_t begin) { return runs.upper_bound(begin); }
  iterator find(std::uint64_t begin) { return runs.find(begin); }
};

// Segments (consecutive, covering [0, size)) in a sorted array and in a tree, likewise.
struct Occupied {
  std::uint64_t end;
  std::uint32_t occupant;  // invalid_index: never used
};

struct SegmentArray {
  struct Entry {
    std::uint64_t begin;
    Occupied value;
  };
  std::vector<Entry> segments;
  using iterator = std::vector<Entry>::iterator;
  static std::uint64_t begin_of(iterator i) { return i->begin; }
  static Occupied& value(iterator i) { return i->value; }
  iterator begin() { return segments.begin(); }
  iterator end() { return segments.end(); }
  [[nodiscard]] std::size_t size() const { return segments.size(); }
  // The segment holding byte `offset` (< the heap's size).
  iterator holding(std::uint64_t offset) {
    return std::partition_point(segments.begin(), segments.end(), [&](const Entry& s) { return s.value.end <= offset; });
  }
  iterator insert(iterator at, std::uint64_t begin, Occupied value) { return segments.insert(at, Entry{begin, value}); }
  iterator erase(iterator first, iterator last) { return segments.erase(first, last); }
  void append(std::uint64_t begin, Occupied value) { segments.push_back(Entry{begin, value}); }
};

struct SegmentTree {
  explicit SegmentTree(NodePool* pool) : segments(PooledMap<std::uint64_t, Occupied>::allocator_type(pool)) {}
  PooledMap<std::uint64_t, Occupied> segments;  // by first byte
  using iterator = PooledMap<std::uint64_t, Occupied>::iterator;
  static std::uint64_t begin_of(iterator i) { return i->first; }
  static Occupied& value(iterator i) { return i->second; }
  iterator begin() { return segments.begin(); }
  iterator end() { return segments.end(); }
  [[nodiscard]] std::size_t size() const { return segments.size(); }
  iterator holding(std::uint64_t offset) { return std::prev(segments.upper_bound(offset)); }
  iterator insert(iterator at, std::uint64_t begin, Occupied value) { return segments.emplace_hint(at, begin, value); }
  iterator erase(iterator first, iterator last) { return segments.erase(first, last); }
  void append(std::uint64_t begin, Occupied value) { segments.emplace_hint(segments.end(), begin, value); }
};

// The free runs by size, then address: the order plain best fit picks in. Kept with the tree
// of free runs.
struct FreeKey {
  std::uint64_t size, begin;
  friend bool operator<(const FreeKey& a, const FreeKey& b) {
    return a.size != b.size ? a.size < b.size : a.begin < b.begin;
  }
};

struct HeapBuilder {
  HeapBuilder()
      : run_tree(&run_nodes), by_size(PoolAllocator<FreeKey>(&size_nodes)), segment_tree(&segment_nodes) {}
  HeapBuilder(const HeapBuilder&) = delete;  // the trees point at their node pools
  HeapBuilder& operator=(const HeapBuilder&) = delete;

  ResourceType type = ResourceType::Texture;
  std::uint32_t type_bits = ~0u;
  std::uint64_t size = 0;
  NodePool run_nodes, size_nodes, segment_nodes;  // before the trees: they outlive them
  bool runs_in_tree = false, segments_in_tree = false;
  RunArray run_array;
  RunTree run_tree;
  std::set<FreeKey, std::less<>, PoolAllocator<FreeKey>> by_size;  // with run_tree
  SegmentArray segment_array;
  SegmentTree segment_tree;

  // The trees take over from this many entries, and hand back below the second number (apart,
  // so that a heap hovering at one size does not switch at every placement).
  static constexpr std::size_t runs_to_tree = 32, runs_to_array = 16;
  static constexpr std::size_t segments_to_tree = 256, segments_to_array = 128;

  void reset(ResourceType heap_type, std::uint32_t bits) {
    type = heap_type;
    type_bits = bits;
    size = 0;
    run_array.runs.clear();
    run_tree.runs.clear();
    by_size.clear();
    segment_array.segments.clear();
    segment_tree.segments.clear();
    runs_in_tree = segments_in_tree = false;
  }

  // Returns the offset; `appended` is set when the resource got a fresh slot at the end of
  // the heap with no padding, whose segment place() has already recorded (occupy() not needed).
  [[gnu::always_inline]] inline std::uint64_t place(std::uint64_t bytes, const Alignment& alignment, std::uint32_t resource,
                                                    bool& appended) {
    if (runs_in_tree) [[unlikely]]
      return place_in_tree(bytes, alignment, resource, appended);
    return place_in(run_array, bytes, alignment, resource, appended);
  }

  [[gnu::always_inline]] inline void release(std::uint64_t offset, std::uint64_t bytes) {
    if (runs_in_tree) [[unlikely]]
      release_in_tree(offset, bytes);
    else
      release_in(run_array, offset, bytes);
  }

  // Marks [offset, offset + bytes) as `resource`'s and appends the previous occupants to
  // `previous` (each once: `previous` holds only this resource's).
  [[gnu::always_inline]] inline void occupy(std::uint64_t offset, std::uint64_t bytes, std::uint32_t resource,
                                            std::vector<std::uint32_t>& previous, std::size_t previous_begin) {
    if (segments_in_tree) [[unlikely]] occupy_in_tree(offset, bytes, resource, previous, previous_begin);
    else occupy_in(segment_array, offset, bytes, resource, previous, previous_begin);
  }

 private:
  // The tree versions out of line: the arrays' are what a frame usually runs, inline.
  // The arrays switch to trees where they grow (see place_in, release_in); the trees back to
  // arrays here, after any change.
  [[gnu::noinline]] std::uint64_t place_in_tree(std::uint64_t bytes, const Alignment& alignment, std::uint32_t resource,
                                                bool& appended) {
    const std::uint64_t offset = place_in(run_tree, bytes, alignment, resource, appended);
    if (run_tree.size() < runs_to_array) runs_to_arrays();
    return offset;
  }
  [[gnu::noinline]] void release_in_tree(std::uint64_t offset, std::uint64_t bytes) {
    release_in(run_tree, offset, bytes);
    if (run_tree.size() < runs_to_array) runs_to_arrays();
  }
  // After an array of free runs grew: a tree from `runs_to_tree` runs on.
  template <class Runs>
  void grew(Runs& free) {
    if constexpr (std::is_same_v<Runs, RunArray>)
      if (free.size() >= runs_to_tree) [[unlikely]] runs_to_trees();
  }
  [[gnu::noinline]] void occupy_in_tree(std::uint64_t offset, std::uint64_t bytes, std::uint32_t resource,
                                        std::vector<std::uint32_t>& previous, std::size_t previous_begin) {
    occupy_in(segment_tree, offset, bytes, resource, previous, previous_begin);
  }
  [[gnu::noinline]] void runs_to_trees() {
    run_tree.runs.clear();
    by_size.clear();
    for (const Range& r : run_array.runs) {
      run_tree.runs.emplace_hint(run_tree.runs.end(), r.begin, r.end);
      by_size.insert(FreeKey{r.end - r.begin, r.begin});
    }
    run_array.runs.clear();
    runs_in_tree = true;
  }
  [[gnu::noinline]] void runs_to_arrays() {
    run_array.runs.clear();
    for (const auto& [begin, end] : run_tree.runs) run_array.runs.push_back(Range{begin, end});
    run_tree.runs.clear();
    by_size.clear();
    runs_in_tree = false;
  }
  // Switches the segments between array and tree when their number crosses a threshold:
  // the check inline (every placement), the switch out of line (rare).
  [[gnu::always_inline]] inline void check_segments() {
    if (segments_in_tree ? segment_tree.size() < segments_to_array : segment_array.size() >= segments_to_tree)
        [[unlikely]]
      switch_segments();
  }
  [[gnu::noinline]] void switch_segments() {
    if (!segments_in_tree) {
      segment_tree.segments.clear();
      for (const SegmentArray::Entry& s : segment_array.segments)
        segment_tree.segments.emplace_hint(segment_tree.segments.end(), s.begin, s.value);
      segment_array.segments.clear();
      segments_in_tree = true;
    } else {
      segment_array.segments.clear();
      for (const auto& [begin, value] : segment_tree.segments) segment_array.segments.push_back({begin, value});
      segment_tree.segments.clear();
      segments_in_tree = false;
    }
  }
  void append_segment(std::uint64_t begin, Occupied value) {
    if (segments_in_tree) segment_tree.append(begin, value);
    else segment_array.append(begin, value);
    check_segments();
  }

  template <class Runs>
  void index_insert(std::uint64_t begin, std::uint64_t end) {
    if constexpr (std::is_same_v<Runs, RunTree>) by_size.insert(FreeKey{end - begin, begin});
  }
  template <class Runs>
  void index_erase(std::uint64_t begin, std::uint64_t end) {
    if constexpr (std::is_same_v<Runs, RunTree>) by_size.erase(FreeKey{end - begin, begin});
  }

  // Best fit among the free runs, else at the end of the heap (growing it, starting inside
  // the trailing free run when there is one). The common cases of a frame -- nothing free (a
  // new slot at the end) and one free run that fits exactly (a chain reusing the memory of a
  // resource two passes back) -- skip the search.
  template <class Runs>
  [[gnu::always_inline]] inline std::uint64_t place_in(Runs& free, std::uint64_t bytes, const Alignment& alignment,
                                                       std::uint32_t resource, bool& appended) {
    appended = false;
    if (free.empty() && bytes > 0) {
      const std::uint64_t at = alignment.up(size);
      if (at == size) {
        size = at + bytes;
        append_segment(at, Occupied{size, resource});
        appended = true;
        return at;
      }
    }
    if (free.size() == 1) {
      const auto only = free.begin();
      const std::uint64_t at = Runs::begin_of(only);
      if (Runs::end_of(only) - at == bytes && alignment.up(at) == at) {
        index_erase<Runs>(at, at + bytes);
        free.erase(only);
        return at;
      }
    }
    constexpr std::uint64_t none = ~0ull;
    std::uint64_t best = none;
    typename Runs::iterator run{};
    if constexpr (std::is_same_v<Runs, RunTree>) {
      // The first run by (size, address) from `bytes` up that fits once aligned.
      for (auto k = by_size.lower_bound(FreeKey{bytes, 0}); k != by_size.end(); ++k) {
        const std::uint64_t at = alignment.up(k->begin);
        if (at + bytes <= k->begin + k->size) {
          best = at;
          run = free.find(k->begin);
          break;
        }
      }
    } else {
      std::uint64_t best_size = none;
      for (auto f = free.begin(); f != free.end(); ++f) {
        const std::uint64_t at = alignment.up(Runs::begin_of(f));
        if (at + bytes <= Runs::end_of(f) && Runs::end_of(f) - Runs::begin_of(f) < best_size) {
          best = at;
          best_size = Runs::end_of(f) - Runs::begin_of(f);
          run = f;
        }
      }
    }
    if (best == none) {
      const bool trailing = !free.empty() && Runs::end_of(std::prev(free.end())) == size;
      if (trailing) {
        run = std::prev(free.end());
        best = alignment.up(Runs::begin_of(run));
        index_erase<Runs>(Runs::begin_of(run), Runs::end_of(run));
        Runs::set_end(run, best + bytes);
      } else {
        best = alignment.up(size);
        run = free.insert(free.end(), size, best + bytes);
      }
      index_insert<Runs>(Runs::begin_of(run), Runs::end_of(run));
      append_segment(size, Occupied{best + bytes, invalid_index});
      size = best + bytes;
    }
    // Carve [best, best + bytes) out of the free run holding it.
    const std::uint64_t whole_begin = Runs::begin_of(run), whole_end = Runs::end_of(run);
    index_erase<Runs>(whole_begin, whole_end);
    typename Runs::iterator after;
    if (best > whole_begin) {
      Runs::set_end(run, best);
      index_insert<Runs>(whole_begin, best);
      after = std::next(run);
    } else {
      after = free.erase(run);
    }
    if (best + bytes < whole_end) {
      free.insert(after, best + bytes, whole_end);
      index_insert<Runs>(best + bytes, whole_end);
    }
    grew(free);  // the fast paths above never add a run
    return best;
  }

  template <class Runs>
  [[gnu::always_inline]] inline void release_in(Runs& free, std::uint64_t offset, std::uint64_t bytes) {
    const std::uint64_t begin = offset, end = offset + bytes;
    // Past every free run (or none): join the last one or append, no search.
    if (free.empty() || Runs::end_of(std::prev(free.end())) <= begin) {
      if (!free.empty() && Runs::end_of(std::prev(free.end())) == begin) {
        const auto last = std::prev(free.end());
        index_erase<Runs>(Runs::begin_of(last), begin);
        Runs::set_end(last, end);
        index_insert<Runs>(Runs::begin_of(last), end);
      } else {
        free.insert(free.end(), begin, end);
        index_insert<Runs>(begin, end);
        grew(free);
      }
      return;
    }
    const auto next = free.upper_bound(begin);  // the first run after the released range
    const bool join_previous = next != free.begin() && Runs::end_of(std::prev(next)) == begin;
    const bool join_next = next != free.end() && Runs::begin_of(next) == end;
    if (join_previous) {
      const auto previous = std::prev(next);
      const std::uint64_t previous_begin = Runs::begin_of(previous);
      index_erase<Runs>(previous_begin, begin);
      std::uint64_t joined_end = end;
      if (join_next) {
        joined_end = Runs::end_of(next);
        index_erase<Runs>(end, joined_end);
        free.erase(next);  // `previous` stays valid: it is before `next`
      }
      Runs::set_end(previous, joined_end);
      index_insert<Runs>(previous_begin, joined_end);
    } else if (join_next) {
      const std::uint64_t next_end = Runs::end_of(next);
      index_erase<Runs>(end, next_end);
      free.move_begin(next, begin);
      index_insert<Runs>(begin, next_end);
    } else {
      free.insert(next, begin, end);
      index_insert<Runs>(begin, end);
      grew(free);
    }
  }

  template <class Segments>
  [[gnu::always_inline]] inline void occupy_in(Segments& segments, std::uint64_t offset, std::uint64_t bytes,
                                               std::uint32_t resource, std::vector<std::uint32_t>& previous,
                                               std::size_t previous_begin) {
    if (bytes == 0) return;
    const std::uint64_t end = offset + bytes;
    auto first = segments.holding(offset);
    Occupied& held = Segments::value(first);
    if (Segments::begin_of(first) == offset && held.end == end) {  // exactly one earlier occupant
      if (held.occupant != invalid_index) previous.push_back(held.occupant);
      held.occupant = resource;
      return;
    }
    auto last = first;
    Occupied tail{};  // the last segment covered, whose bytes past `end` keep their occupant
    for (; last != segments.end() && Segments::begin_of(last) < end; ++last) {
      const Occupied& covered = Segments::value(last);
      if (covered.occupant != invalid_index &&
          std::find(previous.begin() + std::ptrdiff_t(previous_begin), previous.end(), covered.occupant) == previous.end())
        previous.push_back(covered.occupant);
      tail = covered;
    }
    // The first entry becomes the piece before `offset`, or the new segment itself; the rest
    // covered go, and the piece past `end` comes back.
    typename Segments::iterator after;
    if (Segments::begin_of(first) < offset) {
      Segments::value(first).end = offset;
      after = segments.erase(std::next(first), last);
      after = std::next(segments.insert(after, offset, Occupied{end, resource}));
    } else {
      Segments::value(first) = Occupied{end, resource};
      after = segments.erase(std::next(first), last);
    }
    if (tail.end > end) segments.insert(after, end, tail);
    check_segments();  // the exact case above keeps the count
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
    bytes += w * h * layers * texel * std::max(1u, r.sample_count);
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
void add_range_barrier(std::vector<PlannedBarrier>& barriers, std::uint32_t resource, gpu::Access before,
                       gpu::Access after, const TextureRange& range) {
  add_barrier(barriers, resource, before, after);
  barriers.back().range = range;
}

// From Undefined a texture still needs its layout set; a buffer has nothing to wait for.
bool needs_barrier(gpu::Access before, gpu::Access after, bool texture) {
  if (before == gpu::Access::Undefined) return texture;
  return before != after || gpu::is_write(before) || gpu::is_write(after);
}

// A subresource of a texture placed whole for its first use that no pass has touched since:
// it is in the layout of that first state with nothing to wait for, so a use in that same
// state needs no barrier (six passes rendering six faces of a cube are not serialized by
// barriers between them). Marked in the state's spare top bit.
constexpr std::uint8_t untouched_bit = 0x80;
constexpr gpu::Access untouched(gpu::Access a) { return gpu::Access(std::uint8_t(a) | untouched_bit); }
constexpr bool is_untouched(gpu::Access a) { return (std::uint8_t(a) & untouched_bit) != 0; }
constexpr gpu::Access real_state(gpu::Access a) { return gpu::Access(std::uint8_t(a) & ~untouched_bit); }

// The states of a texture used in parts, one per mip and layer (mip-major).
struct Subresources {
  gpu::Access* states;
  std::uint32_t mips, layers;
  [[nodiscard]] gpu::Access& at(std::uint32_t mip, std::uint32_t layer) const { return states[mip * layers + layer]; }
  [[nodiscard]] TextureRange exact(const TextureRange& r) const {
    return {r.base_mip, r.mips_of(mips), r.base_layer, r.layers_of(layers)};
  }
  // Calls fn(rectangle, state) for the subresources of `range`, grouped into rectangles of
  // one state (barriers name rectangles): runs of layers per mip, each run merged with the
  // same run of the mips below it.
  template <class Fn>
  void for_each_block(const TextureRange& range, Fn&& fn) const {
    const TextureRange r = exact(range);
    struct Run {
      std::uint32_t base_layer, count, base_mip, mip_count;
      gpu::Access state;
    };
    std::vector<Run> open, next;
    for (std::uint32_t m = r.base_mip; m < r.base_mip + r.mip_count; ++m) {
      next.clear();
      for (std::uint32_t l = r.base_layer; l < r.base_layer + r.layer_count;) {
        const gpu::Access state = at(m, l);
        std::uint32_t end = l + 1;
        while (end < r.base_layer + r.layer_count && at(m, end) == state) ++end;
        next.push_back({l, end - l, m, 1, state});
        l = end;
      }
      // A run the mip above had too (same layers, same state) grows downwards.
      for (Run& run : next) {
        for (Run& above : open) {
          if (above.count != 0 && above.base_layer == run.base_layer && above.count == run.count &&
              above.state == run.state) {
            run.base_mip = above.base_mip;
            run.mip_count = above.mip_count + 1;
            above.count = 0;  // taken over
            break;
          }
        }
      }
      for (const Run& above : open)
        if (above.count != 0) fn(TextureRange{above.base_mip, above.mip_count, above.base_layer, above.count}, above.state);
      std::swap(open, next);
    }
    for (const Run& run : open) fn(TextureRange{run.base_mip, run.mip_count, run.base_layer, run.count}, run.state);
  }
  void set(const TextureRange& range, gpu::Access state) const {
    const TextureRange r = exact(range);
    for (std::uint32_t m = r.base_mip; m < r.base_mip + r.mip_count; ++m)
      for (std::uint32_t l = r.base_layer; l < r.base_layer + r.layer_count; ++l) at(m, l) = state;
  }
};

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
          info.mip_level_count != last_.mip_level_count || info.dimension != last_.dimension ||
          info.sample_count != last_.sample_count) [[unlikely]] {
        last_.extent = info.extent;
        last_.format = info.format;
        last_.mip_level_count = info.mip_level_count;
        last_.dimension = info.dimension;
        last_.sample_count = info.sample_count;
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
  // Textures used in parts start with every subresource in the texture's starting state.
  const bool any_ranged = graph.subresources;
  if (any_ranged) {
    scratch.sub_begin.assign(R, invalid_index);
    scratch.sub_state.clear();
    for (std::uint32_t r = 0; r < R; ++r) {
      const ResourceNode& node = graph.resources[r];
      if (!node.ranged) continue;
      scratch.sub_begin[r] = std::uint32_t(scratch.sub_state.size());
      scratch.sub_state.resize(scratch.sub_state.size() +
                                   std::size_t(node.texture_desc.mip_level_count) * declared_layers(node.texture_desc),
                               current[r]);
    }
  }
  auto subresources_of = [&](std::uint32_t r) -> std::optional<Subresources> {
    if (!any_ranged || scratch.sub_begin[r] == invalid_index) return std::nullopt;
    const TextureDesc& desc = graph.resources[r].texture_desc;
    return Subresources{scratch.sub_state.data() + scratch.sub_begin[r], desc.mip_level_count, declared_layers(desc)};
  };
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
  std::vector<std::unique_ptr<HeapBuilder>>& heaps = scratch.heaps.heaps;
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
    if (heap == none || (heaps[heap]->type_bits & req->type_bits) == 0) {
      heap = 0;
      while (heap < heap_count && !(heaps[heap]->type == info.type && (heaps[heap]->type_bits & req->type_bits) != 0))
        ++heap;
    }
    if (heap == heap_count) {
      if (heap == heaps.size()) heaps.push_back(std::make_unique<HeapBuilder>());
      heaps[heap]->reset(info.type, req->type_bits);
      ++heap_count;
      only_heap[type] = ++heaps_of_type[type] == 1 ? heap : none;
    }
    HeapBuilder& h = *heaps[heap];
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
          if (const auto parts = a->texture ? subresources_of(occupant) : std::nullopt) [[unlikely]] {
            // Its mips and layers may be in different states: each block moves on its own.
            const bool release = !released[occupant];
            parts->for_each_block(TextureRange{}, [&](const TextureRange& block, gpu::Access part_state) {
              const gpu::Access occupant_before = real_state(part_state);
              const gpu::Access occupant_after = release ? release_state(occupant_before) : occupant_before;
              add_barrier(barriers, r, gpu::Access::Undefined, a->access, occupant, occupant_before, occupant_after);
              barriers.back().range = block;
              parts->set(block, occupant_after);
              state_of[occupant] = occupant_after;
            });
            released[occupant] = 1;
            continue;
          }
          const gpu::Access occupant_before = state_of[occupant];
          const gpu::Access occupant_after =
              a->texture && !released[occupant] ? release_state(occupant_before) : occupant_before;
          add_barrier(barriers, r, gpu::Access::Undefined, a->access, occupant, occupant_before, occupant_after);
          released[occupant] = 1;
          state_of[occupant] = occupant_after;
        }
        // Placed whole, from Undefined: every part of it is in this first state now, and the
        // parts this access does not use are untouched in it.
        if (const auto parts = subresources_of(r)) [[unlikely]] {
          parts->set(TextureRange{}, untouched(a->access));
          parts->set(graph.ranges[a->range], a->access);
        }
      } else if (const auto parts = subresources_of(r)) [[unlikely]] {
        if (!info.used) {
          info.used = true;
          info.first_use = pos;
        }
        // Part by part: a block already in this state for reading needs nothing.
        const TextureRange& range = graph.ranges[a->range];
        parts->for_each_block(range, [&](const TextureRange& block, gpu::Access part_state) {
          const gpu::Access part_before = real_state(part_state);
          if (is_untouched(part_state) ? part_before != a->access : needs_barrier(part_before, a->access, true))
            add_range_barrier(barriers, r, part_before, a->access, block);
        });
        parts->set(range, a->access);
      } else {
        if (!info.used) {
          info.used = true;
          info.first_use = pos;
        }
        if (needs_barrier(before, a->access, a->texture)) add_barrier(barriers, r, before, a->access);
      }
      info.last_use = pos;
      state_of[r] = a->access;
      // A pass with two accesses of one texture (two ranges) frees it once.
      if (last_pass_of[r] == p && (!any_ranged || std::find(ending.begin(), ending.end(), r) == ending.end()))
        ending.push_back(r);
    }
    if (aliasing)
      for (const std::uint32_t r : ending)
        if (info_of[r].heap != invalid_index) heaps[info_of[r].heap]->release(info_of[r].offset, info_of[r].bytes);
  }
  state.barrier_begin[positions] = std::uint32_t(state.barriers.size());

  // Outputs are read after the frame: their lifetimes run to the end.
  for (const OutputNode& out : graph.outputs)
    if (out.resource < R && resources[out.resource].used) resources[out.resource].last_use = positions - 1;
  for (std::uint32_t r = 0; r < R; ++r) {
    const gpu::Access final_state = state.resource_final_state[r];
    if (const auto parts = subresources_of(r); parts && resources[r].used) [[unlikely]] {
      // A texture used in parts ends the frame in one state (outputs in theirs; imports in
      // their last access's, so that the next frame starts from one state): the parts that
      // are not yet in it move.
      if (final_state == gpu::Access::Undefined && !graph.resources[r].imported) continue;
      const gpu::Access end = final_state != gpu::Access::Undefined ? final_state : current[r];
      parts->for_each_block(TextureRange{}, [&](const TextureRange& block, gpu::Access part_state) {
        if (real_state(part_state) != end) add_range_barrier(state.barriers, r, real_state(part_state), end, block);
      });
      parts->set(TextureRange{}, end);
      continue;
    }
    if (final_state == gpu::Access::Undefined || !resources[r].used || current[r] == final_state) continue;
    add_barrier(state.barriers, r, current[r], final_state);
  }
  state.barrier_begin[positions + 1] = std::uint32_t(state.barriers.size());

  groups.number(resources, scratch.alias_group_number);
  for (std::size_t h = 0; h < heap_count; ++h) {
    plan.heaps.push_back(MemoryHeap{heaps[h]->type, heaps[h]->type_bits, heaps[h]->size});
    plan.aliased_bytes += heaps[h]->size;
  }
  state.memory = std::move(plan);
}
}  // namespace weft::detail
