// weft.graph:details — how a graph stores what its passes declare, and setup's fast paths.
// Nothing here is exported: importers cannot name it, but the inline setup paths of the API
// (add_pass, PassBuilder::read/write/create_texture) are compiled into their callers, and
// need these definitions reachable (Filament keeps the same kind of code in fg/details/).
module;
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>
export module weft.graph:details;
import weft.core;
import weft.gpu;
import :types;
import :blackboard;

namespace weft::detail {

struct GraphData;
struct KeptGraphs;     // builder.cpp
struct CompiledState;  // compiled_state.cppm
struct Executor;       // execute.cpp

// The execute callback and the pass data, type-erased once per pass and stored in the
// graph's arena.
struct ErasedExecute {
  void* data = nullptr;
  void* callable = nullptr;
  void (*invoke)(void* callable, const void* data, const PassResources&, PassContext&) = nullptr;
  void (*destroy)(void* callable, void* data) = nullptr;
};

// Per-frame objects a pass hands to PassContext::keep().
struct KeptObject {
  virtual ~KeptObject() = default;
};
template <class T>
struct Kept final : KeptObject {
  explicit Kept(T&& v) : value(std::move(v)) {}
  T value;
};

void* arena_allocate(GraphData& graph, std::size_t size, std::size_t alignment);
// Starts a pass (returns its index) and ends it; add_pass runs the pass's setup between them.
[[gnu::always_inline]] inline std::uint32_t begin_pass(GraphData& graph, std::string_view name, const ErasedExecute& execute);
[[gnu::always_inline]] inline void end_pass(GraphData& graph, std::uint32_t pass);

template <class Data, class Fn>
void invoke_execute(void* callable, const void* data, const PassResources& resources, PassContext& context) {
  (*static_cast<Fn*>(callable))(resources, *static_cast<const Data*>(data), context);
}
template <class Data, class Fn>
void destroy_pass(void* callable, void* data) {
  static_cast<Fn*>(callable)->~Fn();
  static_cast<Data*>(data)->~Data();
}

// Bump allocator for pass data, execute callables and names: one allocation per 16 KiB
// instead of several per pass, and stable addresses (add_pass returns Data&).
class Arena {
 public:
  Arena() = default;
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;
  // Inline: several calls per pass, and the common case is a pointer bump.
  inline void* allocate(std::size_t size, std::size_t alignment) {
    std::byte* p = align(cursor_, alignment);
    const std::size_t used = std::size_t(p - cursor_) + size;
    if (cursor_ == nullptr || used > left_) return allocate_in_next_block(size, alignment);
    left_ -= used;
    cursor_ = p + size;
    return p;
  }
  inline std::string_view copy(std::string_view text) {
    const std::size_t n = text.size();
    if (n == 0) return {};
    auto* p = static_cast<char*>(allocate(n, 1));
    const char* from = text.data();
    // Pass and resource names are short: two overlapping fixed-size copies instead of a call.
    if (n >= 8 && n <= 16) {
      std::uint64_t head, tail;
      std::memcpy(&head, from, 8);
      std::memcpy(&tail, from + n - 8, 8);
      std::memcpy(p, &head, 8);
      std::memcpy(p + n - 8, &tail, 8);
    } else if (n >= 4 && n < 8) {
      std::uint32_t head, tail;
      std::memcpy(&head, from, 4);
      std::memcpy(&tail, from + n - 4, 4);
      std::memcpy(p, &head, 4);
      std::memcpy(p + n - 4, &tail, 4);
    } else {
      std::memcpy(p, from, n);
    }
    return {p, n};
  }
  // Forgets everything allocated and starts again at the first block; the blocks stay.
  void reset();

 private:
  static inline std::byte* align(std::byte* at, std::size_t alignment) {
    const auto address = reinterpret_cast<std::uintptr_t>(at);
    return reinterpret_cast<std::byte*>((address + alignment - 1) & ~(std::uintptr_t(alignment) - 1));
  }
  void* allocate_in_next_block(std::size_t size, std::size_t alignment);
  struct Block {
    std::unique_ptr<std::byte[]> bytes;
    std::size_t size;
  };
  std::vector<Block> blocks_;
  std::size_t block_ = 0;  // the block `cursor_` points into
  std::byte* cursor_ = nullptr;
  std::size_t left_ = 0;
};

// Use bits: one bit per TextureUse/BufferUse value, kept per access.
constexpr std::uint16_t use_bit(TextureUse use) { return std::uint16_t(1u << unsigned(use)); }
constexpr std::uint16_t use_bit(BufferUse use) { return std::uint16_t(1u << unsigned(use)); }

// What setup learns about a pass as it declares, so that compile() need not sweep the
// accesses again to find it: the uses it makes of textures and buffers (its kind), whether it
// writes an imported resource (a root of culling), whether a later pass uses what it wrote
// (when every pass is a root or so used, nothing is culled), and whether its attachments were
// declared with different sizes (compile() then compares the resolved extents).
struct PassNode {
  // Compared byte for byte between frames by same_declarations() up to `name`: values only,
  // and the padding stays zero (nodes are value-initialized and set field by field).
  std::uint32_t first_access = 0;
  std::uint32_t access_count = 0;
  std::uint32_t first_attachment = invalid_index;  // the resource of its first attachment
  std::uint16_t texture_uses = 0, buffer_uses = 0;  // use bits over all its accesses
  PassKind declared_kind = PassKind::Compute;
  bool kind_declared = false;
  bool side_effect = false;
  bool writes_import = false;
  bool attachment_sizes_differ = false;  // as declared (relative or absolute), before resolving
  bool consumed = false;  // a later pass uses a version this pass wrote
  // Not compared: a reused plan takes this frame's names and callbacks.
  std::string_view name;
  ErasedExecute execute;
};

struct ResourceNode {
  // Compared byte for byte between frames by same_declarations() up to `name` (see PassNode):
  // descriptors are therefore copied in field by field, never as whole structs (which would
  // copy the caller's padding). The fields setup reads on every declaration come first.
  ResourceType type = ResourceType::Texture;
  bool imported = false;
  gpu::Access initial_state = gpu::Access::Undefined;
  bool ranged = false;     // some pass uses part of it (a TextureRange): compile tracks its subresources
  std::uint16_t uses = 0;  // use bits over every pass's accesses (its gpu usage)
  std::uint32_t creator = invalid_index;  // the pass that created a transient
  std::uint32_t latest_slot = invalid_index;
  std::uint32_t last_pass = invalid_index;  // the last pass that declared a use of it
  TextureDesc texture_desc;                 // textures
  gpu::TextureUsage imported_texture_usage = gpu::TextureUsage::None;  // None = unknown
  BufferDesc buffer_desc;                   // buffers
  gpu::BufferUsage imported_buffer_usage = gpu::BufferUsage::None;
  // Not compared: names and imported gpu objects may differ between frames of one plan.
  std::string_view name;
  const gpu::Texture* texture = nullptr;  // imported gpu object, if any
  const gpu::Buffer* buffer = nullptr;
};

// Field by field, so that the node's zeroed padding stays zero (see ResourceNode).
inline void set_texture_desc(TextureDesc& to, const TextureDesc& from) {
  to.size.absolute.width = from.size.absolute.width;
  to.size.absolute.height = from.size.absolute.height;
  to.size.absolute.depth_or_layers = from.size.absolute.depth_or_layers;
  to.size.relative.width = from.size.relative.width;
  to.size.relative.height = from.size.relative.height;
  to.size.is_relative = from.size.is_relative;
  to.format = from.format;
  to.mip_level_count = from.mip_level_count;
  to.dimension = from.dimension;
  to.extra_usage = from.extra_usage;
  to.sample_count = from.sample_count;
}

// One version of one resource; versions of a resource link backwards through `previous`.
struct VersionNode {
  std::uint32_t resource = invalid_index;
  std::uint32_t version = 0;
  std::uint32_t producer = invalid_index;     // the pass whose write created it
  std::uint32_t next_writer = invalid_index;  // the pass that writes it into the next version
  std::uint32_t previous = invalid_index;
};

// One pass's use of one resource (several declarations of the same resource by one pass
// are merged into one access, so each pass has one state per resource -- or, where it uses
// disjoint ranges of a texture, one access and one state per range).
struct AccessNode {
  std::uint32_t resource = invalid_index;
  std::uint32_t slot = invalid_index;      // the version read, or the version a write starts from
  std::uint32_t out_slot = invalid_index;  // the version a write produces
  gpu::Access access = gpu::Access::Undefined;
  bool reads = false;
  bool texture = false;   // copies of the resource's type and import flag: compile's hot loops
  bool imported = false;  // then never touch the (large) resource records
  std::uint16_t uses = 0;  // use bits
  std::uint16_t range = 0;  // GraphData::ranges index of the subresources used; 0: the whole resource
  // inline: a member defined in a module's class is not implicitly inline, and compile's
  // loops call this per access.
  [[nodiscard]] inline bool writes() const { return out_slot != invalid_index; }
};
// Every byte is a field with a value, so two access arrays compare with memcmp
// (same_declarations, once per frame over every access).
static_assert(sizeof(AccessNode) == 20 && std::has_unique_object_representations_v<AccessNode>);

struct OutputNode {
  std::uint32_t resource = invalid_index;
  std::uint32_t version = 0;
  gpu::Access final_state = gpu::Access::Undefined;
};

struct GraphData {
  explicit GraphData(std::string_view graph_name);
  GraphData(const GraphData&) = delete;
  GraphData& operator=(const GraphData&) = delete;
  ~GraphData();
  // Destroys the passes' data and callables and empties every array, keeping capacity.
  void clear();
  // Destroys the passes' data and callables but keeps the declarations (last frame's, which
  // the next compile() compares with).
  void release_callbacks();

  std::string name;
  Arena arena;
  std::vector<PassNode> passes;
  std::vector<ResourceNode> resources;
  std::vector<VersionNode> versions;
  std::vector<AccessNode> accesses;
  std::vector<OutputNode> outputs;
  std::vector<GraphError> declaration_errors;
  Blackboard blackboard;
  std::uint32_t current_pass = invalid_index;  // the pass whose setup is running
  // Set by setup when a pass reads a version whose next writer was declared before it (only
  // then can declaration order be an invalid order, or a cycle exist), and when a read might
  // see a version nobody wrote; compile() takes its slow paths only then.
  bool backward_edges = false;
  bool maybe_unwritten_read = false;
  bool multisampled = false;  // some texture has more than one sample: compile checks counts
  // The ranges accesses name (AccessNode::range); ranges[0] is the whole texture. Any other
  // one makes `subresources` true, and compile tracks the states and hazards of the ranged
  // resources' mips and layers one by one.
  std::vector<TextureRange> ranges{TextureRange{}};
  bool subresources = false;
  // Last frame's declarations (the other set of arrays reset() alternates with), which a
  // compiled plan may be reused for; null when there is no last frame.
  GraphData* previous = nullptr;
  bool has_destructors = false;  // some pass's data or callable is not trivially destructible

  [[nodiscard]] std::string describe(std::uint32_t resource) const;  // "texture 'x'"
  [[nodiscard]] std::string_view current_pass_name() const {
    return current_pass == invalid_index ? std::string_view{} : passes[current_pass].name;
  }
  // The version slot a handle names, or invalid_index for a handle this graph never returned.
  [[nodiscard]] std::uint32_t find_slot(std::uint32_t resource, std::uint32_t version) const;

  // The state of a compiled graph that is gone, for the next compile() to reuse. A compiled
  // graph may be destroyed on another thread than the one compiling, hence the lock.
  // compile()'s table of names seen (check_unique_names), kept for its capacity.
  std::vector<std::uint32_t> name_slots;
  std::mutex spare_state_mutex;
  std::unique_ptr<CompiledState> spare_state;
};


// ---- setup's fast paths ----------------------------------------------------------------
// Inline, because a frame's setup runs them for every declaration. The common case -- a
// valid handle at its latest version, the pass's first use of that resource -- is decided
// here in a few comparisons; merging a second declaration and every mistake go to
// builder.cpp, which reports them.

inline constexpr std::uint16_t attachment_use_bits =
    use_bit(TextureUse::ColorAttachment) | use_bit(TextureUse::DepthAttachment) | use_bit(TextureUse::DepthRead);

[[gnu::cold]] void report_nested_pass(GraphData& g, std::string_view name);
[[gnu::cold]] void report_texture_desc(GraphData& g, std::uint32_t resource, const TextureDesc& desc,
                                       std::string_view pass_name);
std::uint32_t declare_slow(GraphData& g, std::uint32_t pass, ResourceType type, std::uint32_t resource,
                           std::uint32_t version, std::uint16_t use, bool write, gpu::Access access,
                           bool wrong_direction);
// A use of part of a texture (out of line: the whole-texture paths above stay as they are).
std::uint32_t declare_range(GraphData& g, std::uint32_t pass, std::uint32_t resource, std::uint32_t version,
                            TextureUse use, bool write, const TextureRange& range);
// Whether two ranges of a texture with `mips` mips and `layers` layers share a subresource.
bool overlap(const TextureRange& a, const TextureRange& b, std::uint32_t mips, std::uint32_t layers);
// A texture's layer count as declared (a relative size has one layer; a 3D texture one).
std::uint32_t declared_layers(const TextureDesc& desc);

inline bool same_declared_size(const TextureSize& a, const TextureSize& b) {
  if (a.is_relative != b.is_relative) return false;
  if (a.is_relative) return a.relative.width == b.relative.width && a.relative.height == b.relative.height;
  return a.absolute.width == b.absolute.width && a.absolute.height == b.absolute.height;
}

// The next version of `resource` after its latest, `after` (the slot of version `version`).
[[gnu::always_inline]] inline std::uint32_t next_version(GraphData& g, std::uint32_t resource, std::uint32_t after,
                                                         std::uint32_t version, std::uint32_t producer) {
  const auto slot = std::uint32_t(g.versions.size());
  // Field by field in place: a VersionNode built on the stack and copied is stored in small
  // pieces and loaded whole, which the CPU cannot forward (a stall per version).
  VersionNode& v = g.versions.emplace_back();
  v.resource = resource;
  v.version = version + 1;
  v.producer = producer;
  v.previous = after;
  g.resources[resource].latest_slot = slot;
  return slot;
}

// The next version after the latest one (every resource has its version 0 from creation).
inline std::uint32_t new_version(GraphData& g, std::uint32_t resource, std::uint32_t producer) {
  const std::uint32_t latest = g.resources[resource].latest_slot;
  return next_version(g, resource, latest, g.versions[latest].version, producer);
}

[[gnu::always_inline]] inline std::uint32_t add_resource(GraphData& g, std::string_view name, ResourceType type, std::uint32_t creator) {
  const auto index = std::uint32_t(g.resources.size());
  // The name is copied before the node is made: its bytes are stored through a char pointer,
  // which may alias anything, so copying it between the node's stores makes the compiler
  // reload what it had kept in registers (a few instructions per resource, measured).
  const std::string_view stored_name = g.arena.copy(name);
  ResourceNode& r = g.resources.emplace_back();
  r.name = stored_name;
  r.type = type;
  r.creator = creator;
  // Version 0, which nobody produced.
  r.latest_slot = std::uint32_t(g.versions.size());
  g.versions.emplace_back().resource = index;
  return index;
}

// What compile() would otherwise learn by sweeping every access again: use bits per pass and
// resource, roots of culling, edges against declaration order, reads nobody may have
// written, attachments declared with different sizes. `slot` is the version the access
// starts from.
[[gnu::always_inline]] inline void note_access(GraphData& g, std::uint32_t pass_index, ResourceNode& node, std::uint32_t resource,
                        ResourceType type, std::uint32_t slot, std::uint16_t use, bool read, bool write) {
  PassNode& pass = g.passes[pass_index];
  node.uses |= use;
  node.last_pass = pass_index;
  if (type == ResourceType::Texture) {
    pass.texture_uses |= use;
    if (use & attachment_use_bits) {
      if (pass.first_attachment == invalid_index) pass.first_attachment = resource;
      else if (!same_declared_size(g.resources[pass.first_attachment].texture_desc.size, node.texture_desc.size))
        pass.attachment_sizes_differ = true;
    }
  } else {
    pass.buffer_uses |= use;
  }
  if (write && node.imported) pass.writes_import = true;
  if (read) {
    const VersionNode& v = g.versions[slot];
    if (v.next_writer != invalid_index && v.next_writer != pass_index) g.backward_edges = true;
    if (v.producer == invalid_index && !(node.imported && v.version == 0)) g.maybe_unwritten_read = true;
  }
}

// Records one use of one resource by `pass`; returns the version the pass leaves it at.
[[gnu::always_inline]] inline std::uint32_t declare(GraphData& g, std::uint32_t pass, ResourceType type, std::uint32_t resource,
                             std::uint32_t version, std::uint16_t use, bool write, gpu::Access access,
                             bool wrong_direction) {
  if (!wrong_direction && resource < g.resources.size()) [[likely]] {
    ResourceNode& node = g.resources[resource];
    const std::uint32_t slot = node.latest_slot;
    VersionNode& input = g.versions[slot];
    if (node.type == type && input.version == version && node.last_pass != pass &&
        !(write && input.next_writer != invalid_index)) [[likely]] {
      // What this pass starts from (read, or written over) makes its producer needed.
      if (input.producer != invalid_index) g.passes[input.producer].consumed = true;
      AccessNode& a = g.accesses.emplace_back();
      a.resource = resource;
      a.slot = slot;
      a.access = access;
      a.uses = use;
      a.reads = !write;
      a.texture = type == ResourceType::Texture;
      a.imported = node.imported;
      if (write) {
        input.next_writer = pass;
        a.out_slot = next_version(g, resource, slot, version, pass);  // `input` is stale from here on
      }
      note_access(g, pass, node, resource, type, slot, use, !write, write);
      return write ? version + 1 : version;
    }
  }
  return declare_slow(g, pass, type, resource, version, use, write, access, wrong_direction);
}

inline std::uint32_t begin_pass(GraphData& g, std::string_view name, const ErasedExecute& execute) {
  const auto index = std::uint32_t(g.passes.size());
  if (g.current_pass != invalid_index) [[unlikely]]
    report_nested_pass(g, name);
  const std::string_view stored_name = g.arena.copy(name);  // first: see add_resource
  PassNode& pass = g.passes.emplace_back();
  pass.name = stored_name;
  pass.first_access = std::uint32_t(g.accesses.size());
  pass.execute = execute;
  if (execute.destroy) g.has_destructors = true;
  g.current_pass = index;
  return index;
}

inline void end_pass(GraphData& g, std::uint32_t pass) {
  g.passes[pass].access_count = std::uint32_t(g.accesses.size()) - g.passes[pass].first_access;
  g.current_pass = invalid_index;
}

}  // namespace weft::detail
