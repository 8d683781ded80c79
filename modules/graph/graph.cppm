// weft.graph — the render graph. Passes declare the resources they create, read and write;
// compile() validates the whole graph (reporting every error at once), culls what reaches no
// output, orders passes, aliases transient memory and derives barriers; the compiled graph
// records one command stream on a weft.gpu device with a debug label and timestamps per pass.
// Declaration, validation, culling, ordering, aliasing and barrier planning need no device.
// A graph rebuilt every frame is reset() and filled again, reusing its memory.
module;
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <functional>
#include <memory>
#include <mutex>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>
export module weft.graph;
import weft.core;
import weft.gpu;

namespace weft::detail {
struct GraphData;
struct CompiledState;
struct Executor;
}  // namespace weft::detail

export namespace weft {

inline constexpr std::uint32_t invalid_index = ~0u;

// ---- handles ---------------------------------------------------------------------------
// A resource index plus a version: every write returns the next version, so the order of a
// read after a write is explicit in the handles. The tag keeps a texture handle from being
// passed where a buffer is expected.
template <class Tag>
struct ResourceHandle {
  std::uint32_t index = invalid_index;
  std::uint32_t version = 0;
  [[nodiscard]] constexpr bool valid() const { return index != invalid_index; }
  constexpr explicit operator bool() const { return valid(); }
  friend constexpr bool operator==(ResourceHandle, ResourceHandle) = default;
};
struct TextureTag {};
struct BufferTag {};
using TextureHandle = ResourceHandle<TextureTag>;
using BufferHandle = ResourceHandle<BufferTag>;

// ---- usages ----------------------------------------------------------------------------
// How a pass uses a resource. Each use maps to the gpu::Access the barrier planner works
// with and to the gpu usage flag a transient resource is created with.
enum class TextureUse : std::uint8_t {
  Sampled, StorageRead, StorageWrite, ColorAttachment, DepthAttachment, DepthRead, CopySrc, CopyDst,
};
enum class BufferUse : std::uint8_t { Vertex, Index, Uniform, StorageRead, StorageWrite, Indirect, CopySrc, CopyDst };

std::string_view to_string(TextureUse use);
std::string_view to_string(BufferUse use);
constexpr gpu::Access access_of(TextureUse use) {
  switch (use) {
    case TextureUse::Sampled: return gpu::Access::ShaderRead;
    case TextureUse::StorageRead: return gpu::Access::StorageRead;
    case TextureUse::StorageWrite: return gpu::Access::StorageWrite;
    case TextureUse::ColorAttachment: return gpu::Access::ColorAttachment;
    case TextureUse::DepthAttachment: return gpu::Access::DepthAttachment;
    case TextureUse::DepthRead: return gpu::Access::DepthRead;
    case TextureUse::CopySrc: return gpu::Access::CopySrc;
    case TextureUse::CopyDst: return gpu::Access::CopyDst;
  }
  return gpu::Access::Undefined;
}

constexpr gpu::Access access_of(BufferUse use) {
  switch (use) {
    case BufferUse::Vertex: return gpu::Access::VertexBuffer;
    case BufferUse::Index: return gpu::Access::IndexBuffer;
    case BufferUse::Uniform: return gpu::Access::UniformRead;
    case BufferUse::StorageRead: return gpu::Access::StorageRead;
    case BufferUse::StorageWrite: return gpu::Access::StorageWrite;
    case BufferUse::Indirect: return gpu::Access::IndirectBuffer;
    case BufferUse::CopySrc: return gpu::Access::CopySrc;
    case BufferUse::CopyDst: return gpu::Access::CopyDst;
  }
  return gpu::Access::Undefined;
}

constexpr gpu::TextureUsage usage_of(TextureUse use) {
  using U = gpu::TextureUsage;
  switch (use) {
    case TextureUse::Sampled: return U::Sampled;
    case TextureUse::StorageRead:
    case TextureUse::StorageWrite: return U::Storage;
    case TextureUse::ColorAttachment: return U::ColorAttachment;
    case TextureUse::DepthAttachment: return U::DepthAttachment;
    // A read-only depth attachment that shaders may also sample (Access::DepthRead covers both).
    case TextureUse::DepthRead: return U::DepthAttachment | U::Sampled;
    case TextureUse::CopySrc: return U::CopySrc;
    case TextureUse::CopyDst: return U::CopyDst;
  }
  return U::None;
}

constexpr gpu::BufferUsage usage_of(BufferUse use) {
  using U = gpu::BufferUsage;
  switch (use) {
    case BufferUse::Vertex: return U::Vertex;
    case BufferUse::Index: return U::Index;
    case BufferUse::Uniform: return U::Uniform;
    case BufferUse::StorageRead:
    case BufferUse::StorageWrite: return U::Storage;
    case BufferUse::Indirect: return U::Indirect;
    case BufferUse::CopySrc: return U::CopySrc;
    case BufferUse::CopyDst: return U::CopyDst;
  }
  return U::None;
}

constexpr bool is_write(TextureUse use) {
  return use == TextureUse::StorageWrite || use == TextureUse::ColorAttachment ||
         use == TextureUse::DepthAttachment || use == TextureUse::CopyDst;
}
constexpr bool is_write(BufferUse use) { return use == BufferUse::StorageWrite || use == BufferUse::CopyDst; }

enum class PassKind : std::uint8_t { Render, Compute, Transfer };
std::string_view to_string(PassKind kind);

enum class ResourceType : std::uint8_t { Texture, Buffer };

// ---- descriptors -----------------------------------------------------------------------
// A size relative to CompileOptions::output_extent: RelativeSize{0.5f} is half the output.
struct RelativeSize {
  float width = 1.0f, height = 1.0f;
  constexpr RelativeSize() = default;
  constexpr RelativeSize(float scale) : width(scale), height(scale) {}  // NOLINT: implicit by design
  constexpr RelativeSize(float w, float h) : width(w), height(h) {}
};

// Either an absolute extent or one relative to the graph's output.
struct TextureSize {
  gpu::Extent3D absolute{0, 0, 1};
  RelativeSize relative{};
  bool is_relative = true;
  constexpr TextureSize() = default;
  constexpr TextureSize(RelativeSize r) : relative(r), is_relative(true) {}      // NOLINT
  constexpr TextureSize(gpu::Extent3D e) : absolute(e), is_relative(false) {}    // NOLINT
  // The extent for an output of `output` (relative sizes round down, never below 1).
  [[nodiscard]] gpu::Extent3D resolve(gpu::Extent3D output) const;
};

struct TextureDesc {
  TextureSize size;
  gpu::Format format = gpu::Format::RGBA8Unorm;
  std::uint32_t mip_level_count = 1;
  gpu::TextureDimension dimension = gpu::TextureDimension::D2;
  // Usages beyond the declared ones (the declared uses add theirs automatically).
  gpu::TextureUsage extra_usage = gpu::TextureUsage::None;
};

struct BufferDesc {
  std::uint64_t size = 0;
  gpu::BufferUsage extra_usage = gpu::BufferUsage::None;
};

// ---- errors ----------------------------------------------------------------------------
enum class GraphErrorKind : std::uint8_t {
  Cycle,                      // passes depend on each other in a loop
  UnwrittenRead,              // a read of a version no pass writes and nothing imports
  MultipleWriters,            // two passes write the same version of a resource
  UnsupportedUsage,           // a usage the texture's format cannot take
  MissingUsage,               // an imported resource was created without a usage a pass needs
  MismatchedAttachmentSizes,  // attachments of one render pass differ in size
  OutputNeverWritten,         // mark_output() of a version no pass writes
  UndeclaredAccess,           // execute touched a resource its setup did not declare
  InvalidHandle,              // a handle this graph never returned
  ConflictingUsage,           // one pass uses one resource two incompatible ways
  InvalidDescriptor,          // zero sizes, relative size without an output extent, ...
  WrongPassKind,              // a declared pass kind that its uses contradict
  Memory,                     // the device refused to size or place a transient resource
};
std::string_view to_string(GraphErrorKind kind);

struct GraphError {
  GraphErrorKind kind = GraphErrorKind::Cycle;
  std::string message;
  std::vector<std::string> passes;     // every pass involved, in the order the message names them
  std::vector<std::string> resources;  // every resource involved
};

// Every problem compile() found, in a stable order (declaration errors first).
struct GraphErrors {
  std::string graph_name;
  std::vector<GraphError> errors;

  [[nodiscard]] bool empty() const { return errors.empty(); }
  [[nodiscard]] std::size_t size() const { return errors.size(); }
  [[nodiscard]] std::size_t count(GraphErrorKind kind) const;
  [[nodiscard]] const GraphError* find(GraphErrorKind kind) const;
  // "render graph 'frame': 2 errors:\n  - ...\n  - ..."
  [[nodiscard]] std::string to_string() const;
  [[nodiscard]] Error to_error() const { return Error{ErrorKind::Graph, to_string()}; }
  operator Error() const { return to_error(); }  // NOLINT: lets Result<T> code `return std::unexpected(Error(errs))`
};

// ---- compile / execute options and results ----------------------------------------------
struct CompileOptions {
  // The extent relative sizes are measured against ({0,0} = unset: relative sizes are errors).
  gpu::Extent3D output_extent{0, 0, 1};
  // With a device, transient memory is sized by Device::memory_requirements; without one it
  // is estimated (texels * bytes per texel over all mips, rounded up to 64 KiB), unless the
  // functions below are given. Execute re-plans with its device's real requirements.
  const gpu::Device* device = nullptr;
  std::function<Result<gpu::MemoryRequirements>(const gpu::TextureDescriptor&)> texture_requirements;
  std::function<Result<gpu::MemoryRequirements>(const gpu::BufferDescriptor&)> buffer_requirements;
  bool aliasing = true;
};

struct ExecuteOptions {
  bool timestamps = true;  // per-pass GPU times (when the adapter supports timestamps)
};

struct PassStats {
  std::string name;
  PassKind kind = PassKind::Compute;
  double gpu_ms = -1.0;        // -1 when timestamps are off or unsupported
  double cpu_record_us = 0.0;  // time spent in the pass's execute callback
};

struct FrameStats {
  std::vector<PassStats> passes;  // in execution order
  double gpu_total_ms = -1.0;
  double cpu_record_total_us = 0.0;  // all execute callbacks plus barriers and labels
  double cpu_frame_ms = 0.0;         // record + submit + wait
  std::uint64_t transient_bytes = 0;           // device memory the aliased transients occupy
  std::uint64_t transient_bytes_unaliased = 0; // what they would occupy without aliasing
  // A markdown table: pass | kind | GPU ms | CPU record µs, with a total row.
  [[nodiscard]] std::string format_table() const;
};

// ---- introspection of a compiled graph --------------------------------------------------
struct PassInfo {
  std::string_view name;
  PassKind kind = PassKind::Compute;
  bool kind_declared = false;
  bool side_effect = false;
  bool culled = false;
  std::uint32_t order_position = invalid_index;  // position in order(); invalid when culled
};

struct ResourceInfo {
  std::string_view name;
  ResourceType type = ResourceType::Texture;
  bool imported = false;
  bool used = false;                          // some non-culled pass uses it
  std::uint32_t first_use = invalid_index;    // order positions (inclusive)
  std::uint32_t last_use = invalid_index;
  // Textures: the resolved descriptor fields; buffers: size.
  gpu::Extent3D extent{};
  gpu::Format format = gpu::Format::Undefined;
  std::uint32_t mip_level_count = 1;
  gpu::TextureDimension dimension = gpu::TextureDimension::D2;
  gpu::TextureUsage texture_usage = gpu::TextureUsage::None;  // derived from every declared use
  std::uint64_t buffer_size = 0;
  gpu::BufferUsage buffer_usage = gpu::BufferUsage::None;
  // Transient memory placement (heap == invalid_index: imported or unused).
  std::uint32_t heap = invalid_index;
  std::uint64_t offset = 0;
  std::uint64_t bytes = 0;
  std::uint32_t alias_group = invalid_index;  // resources sharing memory share a group
};

// A barrier the graph records before a pass (or at the end of the frame for outputs).
// previous_occupant is set when `resource` takes over memory another transient used earlier
// in the frame: `resource` starts from Undefined, and the previous occupant is moved from
// occupant_before to occupant_after first (a layout change the first time its memory is
// taken over, nothing after that), so the new resource's transition waits for it.
struct PlannedBarrier {
  std::uint32_t resource = invalid_index;
  gpu::Access before = gpu::Access::Undefined;
  gpu::Access after = gpu::Access::Undefined;
  std::uint32_t previous_occupant = invalid_index;
  gpu::Access occupant_before = gpu::Access::Undefined;
  gpu::Access occupant_after = gpu::Access::Undefined;
};

struct MemoryHeap {
  ResourceType type = ResourceType::Texture;  // textures and buffers never share a heap
  std::uint32_t type_bits = ~0u;
  std::uint64_t size = 0;
};

struct MemoryPlan {
  std::vector<MemoryHeap> heaps;
  std::uint64_t aliased_bytes = 0;    // sum of heap sizes
  std::uint64_t unaliased_bytes = 0;  // sum of transient sizes, as if each had its own memory
  bool from_device = false;           // sized by Device::memory_requirements, not estimated
};

class RenderGraph;
class PassBuilder;
class PassResources;
class PassContext;
class CompiledGraph;

}  // namespace weft

// ---- internals the templates below need (not exported) ---------------------------------
namespace weft::detail {

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
[[gnu::always_inline]] inline PassBuilder begin_pass(GraphData& graph, std::string_view name, const ErasedExecute& execute);
[[gnu::always_inline]] inline void end_pass(GraphData& graph, std::uint32_t pass);
inline std::uint32_t builder_pass(const PassBuilder& builder);

template <class Data, class Fn>
void invoke_execute(void* callable, const void* data, const PassResources& resources, PassContext& context) {
  (*static_cast<Fn*>(callable))(resources, *static_cast<const Data*>(data), context);
}
template <class Data, class Fn>
void destroy_pass(void* callable, void* data) {
  static_cast<Fn*>(callable)->~Fn();
  static_cast<Data*>(data)->~Data();
}

}  // namespace weft::detail

export namespace weft {

// ---- blackboard ------------------------------------------------------------------------
// Well-known handles passed between features by name ("scene_depth", "shadow_map"), so a
// feature finds another's output without importing it. put() replaces an existing key.
class Blackboard {
 public:
  void put(std::string_view key, TextureHandle handle);
  void put(std::string_view key, BufferHandle handle);
  // The handle under `key`, or an error naming the key and the pass that asked.
  template <class Handle>
  [[nodiscard]] Result<Handle> get(std::string_view key) const {
    if constexpr (std::is_same_v<Handle, TextureHandle>) {
      auto found = find_entry(key, ResourceType::Texture);
      if (!found) return std::unexpected(missing(key, ResourceType::Texture));
      return TextureHandle{found->first, found->second};
    } else {
      static_assert(std::is_same_v<Handle, BufferHandle>, "get<TextureHandle> or get<BufferHandle>");
      auto found = find_entry(key, ResourceType::Buffer);
      if (!found) return std::unexpected(missing(key, ResourceType::Buffer));
      return BufferHandle{found->first, found->second};
    }
  }
  template <class Handle>
  [[nodiscard]] std::optional<Handle> find(std::string_view key) const {
    auto handle = get<Handle>(key);
    return handle ? std::optional<Handle>(*handle) : std::nullopt;
  }
  [[nodiscard]] bool contains(std::string_view key) const;
  [[nodiscard]] std::vector<std::string> keys() const;

 private:
  struct Entry {
    std::string key;
    ResourceType type;
    std::uint32_t index, version;
  };
  void put_entry(std::string_view key, ResourceType type, std::uint32_t index, std::uint32_t version);
  [[nodiscard]] std::optional<std::pair<std::uint32_t, std::uint32_t>> find_entry(std::string_view key,
                                                                                  ResourceType type) const;
  [[nodiscard]] Error missing(std::string_view key, ResourceType type) const;
  const detail::GraphData* graph_ = nullptr;  // to name the pass that is asking
  std::vector<Entry> entries_;
  friend struct detail::GraphData;
};

// ---- setup -----------------------------------------------------------------------------
// Handed to a pass's setup callback: everything the pass will touch is declared here.
class PassBuilder {
 public:
  // A transient texture/buffer owned by the graph; its gpu usage flags are derived from every
  // use declared on it, and its memory may be shared with transients that are not alive at
  // the same time. Its version 0 has no contents: write it before reading it.
  TextureHandle create_texture(std::string_view name, const TextureDesc& desc);
  BufferHandle create_buffer(std::string_view name, const BufferDesc& desc);

  // Reads return the handle they were given; writes return the next version, which later
  // passes must use to see this pass's results.
  TextureHandle read(TextureHandle handle, TextureUse use);
  BufferHandle read(BufferHandle handle, BufferUse use);
  [[nodiscard]] TextureHandle write(TextureHandle handle, TextureUse use);
  [[nodiscard]] BufferHandle write(BufferHandle handle, BufferUse use);

  // Keeps the pass even when nothing it writes reaches an output (e.g. it uploads uniforms
  // or writes a readback buffer the graph does not know about).
  void side_effect();
  // Declares the pass kind; without it the kind is inferred (attachments or vertex/index
  // buffers: render; only copies: transfer; otherwise compute).
  void kind(PassKind kind);

  [[nodiscard]] Blackboard& blackboard();
  [[nodiscard]] std::string_view pass_name() const;

 private:
  inline PassBuilder(detail::GraphData* graph, std::uint32_t pass) : graph_(graph), pass_(pass) {}
  detail::GraphData* graph_;
  std::uint32_t pass_;
  friend inline PassBuilder detail::begin_pass(detail::GraphData&, std::string_view, const detail::ErasedExecute&);
  friend inline std::uint32_t detail::builder_pass(const PassBuilder&);
};

// ---- execute ---------------------------------------------------------------------------
// What a pass's execute callback may touch: only the resources its setup declared. Asking
// for anything else records an UndeclaredAccess error that execute() returns.
class PassResources {
 public:
  [[nodiscard]] const gpu::Texture& texture(TextureHandle handle) const;
  [[nodiscard]] const gpu::TextureView& view(TextureHandle handle) const;
  [[nodiscard]] const gpu::Buffer& buffer(BufferHandle handle) const;
  [[nodiscard]] gpu::Extent3D extent(TextureHandle handle) const;

 private:
  PassResources(detail::Executor* executor, std::uint32_t pass) : executor_(executor), pass_(pass) {}
  detail::Executor* executor_;
  std::uint32_t pass_;
  friend struct detail::Executor;
};

class PassContext {
 public:
  [[nodiscard]] gpu::CommandEncoder& encoder() const { return *encoder_; }
  [[nodiscard]] gpu::Device& device() const { return *device_; }
  [[nodiscard]] std::string_view pass_name() const { return pass_name_; }
  [[nodiscard]] std::uint64_t frame_index() const { return frame_index_; }

  // Keeps an object made for this frame (typically a bind group over this frame's
  // resources) alive until the frame's commands have finished on the GPU.
  template <class T>
    requires(!std::is_lvalue_reference_v<T>)
  T& keep(T&& object) const {
    auto holder = std::make_unique<detail::Kept<T>>(std::move(object));
    T& value = holder->value;
    keep_alive(std::move(holder));
    return value;
  }

 private:
  PassContext() = default;
  void keep_alive(std::unique_ptr<detail::KeptObject> object) const;
  detail::Executor* executor_ = nullptr;
  gpu::CommandEncoder* encoder_ = nullptr;
  gpu::Device* device_ = nullptr;
  std::string_view pass_name_;
  std::uint64_t frame_index_ = 0;
  friend struct detail::Executor;
};

}  // namespace weft

export namespace weft {

// ---- the graph -------------------------------------------------------------------------
class RenderGraph {
 public:
  explicit RenderGraph(std::string_view name = "frame");
  RenderGraph(RenderGraph&&) noexcept;
  RenderGraph& operator=(RenderGraph&&) noexcept;
  ~RenderGraph();

  // Empties the graph for the next frame's passes (Frostbite's rebuild-every-frame loop),
  // keeping the memory of its arrays, its arena and its last compile's working state, so a
  // graph rebuilt with the same shape allocates nothing. Handles, the Data& add_pass
  // returned and the blackboard's entries are invalid afterwards.
  // The graph alternates between two sets of arrays, so this frame's declarations are kept
  // while the next frame's are made: when they turn out identical (the same passes declaring
  // the same uses of the same resources, the same outputs, the same compile options) and last
  // frame's compiled graph is gone, compile() reuses its plan -- order, memory, barriers and
  // the gpu objects it created -- instead of planning again (CompiledGraph::plan_reused()).
  // Keeping last frame's compiled graph while building this frame's also allocates nothing
  // (it is then not reused). Objects captured by the execute callbacks are destroyed here,
  // or, while a compiled graph still needs them, when it is gone and their arrays are reused.
  void reset();

  // Adds a pass: setup(PassBuilder&, Data&) runs now and fills Data with handles;
  // execute(const PassResources&, const Data&, PassContext&) runs at every execute() unless
  // the pass is culled. The returned Data stays valid for the graph's lifetime.
  template <class Data, class Setup, class Execute>
  Data& add_pass(std::string_view name, Setup&& setup, Execute&& execute) {
    static_assert(std::is_invocable_v<Setup&, PassBuilder&, Data&>,
                  "setup must be callable as setup(PassBuilder&, Data&)");
    static_assert(std::is_invocable_v<std::decay_t<Execute>&, const PassResources&, const Data&, PassContext&>,
                  "execute must be callable as execute(const PassResources&, const Data&, PassContext&)");
    using Fn = std::decay_t<Execute>;
    auto* data = new (detail::arena_allocate(*data_, sizeof(Data), alignof(Data))) Data{};
    auto* callable = new (detail::arena_allocate(*data_, sizeof(Fn), alignof(Fn))) Fn(std::forward<Execute>(execute));
    detail::ErasedExecute erased{data, callable, &detail::invoke_execute<Data, Fn>, nullptr};
    if constexpr (!std::is_trivially_destructible_v<Data> || !std::is_trivially_destructible_v<Fn>)
      erased.destroy = &detail::destroy_pass<Data, Fn>;
    PassBuilder builder = detail::begin_pass(*data_, name, erased);
    setup(builder, *data);
    detail::end_pass(*data_, detail::builder_pass(builder));
    return *data;
  }

  // A pass that only declares (no execute callback): graph tests and placeholders.
  template <class Setup>
  void add_pass(std::string_view name, Setup&& setup) {
    static_assert(std::is_invocable_v<Setup&, PassBuilder&>, "setup must be callable as setup(PassBuilder&)");
    PassBuilder builder = detail::begin_pass(*data_, name, detail::ErasedExecute{});
    setup(builder);
    detail::end_pass(*data_, detail::builder_pass(builder));
  }

  // Persistent resources owned by the caller (LUTs, baked data, the frame output, last
  // frame's history). `initial_state` is the state the resource is in when the frame
  // starts. The descriptor-only forms need no device (graph tests); execute() then fails if
  // a pass that is not culled uses them.
  TextureHandle import_texture(std::string_view name, const gpu::Texture* texture, gpu::Access initial_state);
  TextureHandle import_texture(std::string_view name, const gpu::TextureDescriptor& desc, gpu::Access initial_state);
  BufferHandle import_buffer(std::string_view name, const gpu::Buffer* buffer, gpu::Access initial_state);
  BufferHandle import_buffer(std::string_view name, const gpu::BufferDescriptor& desc, gpu::Access initial_state);

  // What the frame produces: passes that contribute to an output are kept, the rest culled.
  // `final_state` (if not Undefined) is the state the resource is left in, e.g. CopySrc for
  // a readback.
  void mark_output(TextureHandle handle, gpu::Access final_state = gpu::Access::Undefined);
  void mark_output(BufferHandle handle, gpu::Access final_state = gpu::Access::Undefined);

  [[nodiscard]] Blackboard& blackboard();
  [[nodiscard]] const std::string& name() const;
  [[nodiscard]] std::size_t pass_count() const;
  [[nodiscard]] std::size_t resource_count() const;
  [[nodiscard]] std::string_view resource_name(std::uint32_t index) const;

  // Validates, culls, orders, plans memory and barriers. The compiled graph keeps what it
  // needs of this graph alive; passes added later are not part of it. After reset(), a frame
  // that declares exactly what the last one did takes the last compiled graph's plan over
  // once that is gone (see reset()): the result is the same, for the cost of a comparison.
  [[nodiscard]] std::expected<CompiledGraph, GraphErrors> compile(const CompileOptions& options = {}) const;

 private:
  std::shared_ptr<detail::GraphData> data_;
  std::shared_ptr<detail::GraphData> spare_;  // the other set of arrays reset() switches between
};

// ---- the compiled graph ----------------------------------------------------------------
class CompiledGraph {
 public:
  CompiledGraph(CompiledGraph&&) noexcept;
  CompiledGraph& operator=(CompiledGraph&&) noexcept;
  ~CompiledGraph();

  // Records every pass into one command encoder (debug group + timestamps per pass), submits
  // and waits. Transient resources are created on the first call (or when the device
  // changes) in memory blocks at the aliasing offsets and reused by later calls.
  Result<FrameStats> execute(gpu::Device& device, const ExecuteOptions& options = {});

  [[nodiscard]] std::string_view name() const;
  [[nodiscard]] std::span<const std::uint32_t> order() const;  // pass indices, execution order
  [[nodiscard]] std::span<const PassInfo> passes() const;       // by declaration index
  [[nodiscard]] std::span<const ResourceInfo> resources() const;
  [[nodiscard]] std::optional<std::uint32_t> find_pass(std::string_view name) const;
  [[nodiscard]] std::optional<std::uint32_t> find_resource(std::string_view name) const;
  [[nodiscard]] bool culled(std::string_view pass_name) const;  // true also for unknown names
  [[nodiscard]] std::span<const PlannedBarrier> barriers_before(std::uint32_t pass) const;
  [[nodiscard]] std::span<const PlannedBarrier> final_barriers() const;
  [[nodiscard]] const MemoryPlan& memory() const;
  // Whether compile() took last frame's plan over (see RenderGraph::reset()).
  [[nodiscard]] bool plan_reused() const;

  // The gpu object behind a handle after execute() (transient or imported), or null.
  [[nodiscard]] const gpu::Texture* texture(TextureHandle handle) const;
  [[nodiscard]] const gpu::Buffer* buffer(BufferHandle handle) const;

  // Graphviz: passes as boxes (culled ones grey, dashed), resources as ellipses coloured by
  // aliasing group, edges labelled with the use.
  [[nodiscard]] std::string to_dot() const;
  // Order, lifetimes, memory placement and barriers as text.
  [[nodiscard]] std::string dump() const;

 private:
  explicit CompiledGraph(std::unique_ptr<detail::CompiledState> state);
  std::unique_ptr<detail::CompiledState> state_;
  friend class RenderGraph;
};

}  // namespace weft

// ---- internals shared by the implementation units (not exported) ------------------------
namespace weft::detail {

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
// are merged into one access, so each pass has one state per resource).
struct AccessNode {
  std::uint32_t resource = invalid_index;
  std::uint32_t slot = invalid_index;      // the version read, or the version a write starts from
  std::uint32_t out_slot = invalid_index;  // the version a write produces
  gpu::Access access = gpu::Access::Undefined;
  bool reads = false;
  bool texture = false;   // copies of the resource's type and import flag: compile's hot loops
  bool imported = false;  // then never touch the (large) resource records
  std::uint16_t uses = 0;  // use bits
  std::uint16_t unused = 0;  // what would be padding, named, so that every byte has a value
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
  std::mutex spare_state_mutex;
  std::unique_ptr<CompiledState> spare_state;
};

// compile()'s working memory, kept with the compiled state so that a recompile reuses it.
// scratch.last_pass of an output: its memory is kept to the end of the frame.
inline constexpr std::uint32_t kept_to_end = invalid_index - 1;

struct HeapBuilder;  // frame_plan.cpp
struct HeapBuilders {  // the memory planner's heaps, kept with their arrays' capacity
  HeapBuilders();
  ~HeapBuilders();
  std::vector<HeapBuilder> heaps;
};
struct CompileScratch {
  std::vector<std::uint8_t> alive;
  std::vector<std::uint32_t> stack;
  std::vector<std::uint32_t> last_pass;  // per resource: the last pass using it (release after it)
  std::vector<std::uint32_t> alias_group_of, alias_group_parent, alias_group_number;
  std::vector<gpu::Access> current;
  std::vector<std::uint8_t> released;
  HeapBuilders heaps;
};

struct Realized;  // gpu objects of an executed graph (execute.cpp)

struct CompiledState {
  CompiledState();
  CompiledState(const CompiledState&) = delete;
  CompiledState& operator=(const CompiledState&) = delete;
  ~CompiledState();

  std::shared_ptr<GraphData> graph;
  CompileOptions options;
  std::uint32_t pass_count = 0, resource_count = 0;  // what this snapshot covers

  std::vector<PassInfo> passes;
  std::vector<std::uint32_t> order;
  std::vector<ResourceInfo> resources;
  std::vector<gpu::Access> resource_final_state;  // Undefined: leave as last used

  // Memory: per resource, the transients whose memory it takes over:
  // takeovers[takeover_first[r] .. takeover_first[r] + takeover_count[r]).
  std::vector<std::uint32_t> takeover_first, takeover_count;
  std::vector<std::uint32_t> takeovers;
  MemoryPlan memory;

  // Barriers: those before order position i are barriers[barrier_begin[i] .. barrier_begin[i+1]);
  // the last range (i == order.size()) is the end of the frame.
  std::vector<PlannedBarrier> barriers;
  std::vector<std::uint32_t> barrier_begin;

  std::unique_ptr<Realized> realized;
  std::uint64_t frame_index = 0;
  CompileScratch scratch;
  // What the plan was made for, to decide whether the next frame may reuse it: the options
  // compile() was given (execute() may re-plan memory for its device), and whether it was.
  gpu::Extent3D planned_output_extent{};
  const gpu::Device* planned_device = nullptr;
  bool planned_aliasing = true;
  bool planned_custom_sizes = false;
  bool reused = false;
};

// Whether `now` declares exactly what `before` did, so a plan made for one serves the other:
// the same passes with the same uses of the same resources in the same order, the same
// descriptors, imports and outputs. Names and execute callbacks may differ.
bool same_declarations(const GraphData& now, const GraphData& before);
// Destroys the gpu objects an executed plan created (execute.cpp, where they are defined).
void drop_gpu_objects(CompiledState& state);

// The state a texture is moved to when another transient first takes over (part of) its
// memory: always a different image layout than its last one, with shader stages. The layout
// change makes the release a write that the synchronization validation (and the driver)
// orders the new resource's transition after; the shader stages chain with the stages the
// new resource's barrier waits for (see execute.cpp). GENERAL (StorageRead) fits every image;
// an image last in GENERAL goes to SHADER_READ_ONLY (ShaderRead), which is why transient
// storage textures also get Sampled usage.
constexpr gpu::Access release_state(gpu::Access last) {
  const bool general = last == gpu::Access::StorageRead || last == gpu::Access::StorageWrite ||
                       last == gpu::Access::HostRead || last == gpu::Access::HostWrite;
  return general ? gpu::Access::ShaderRead : gpu::Access::StorageRead;
}

// Compile stages (one file each), run in this order by RenderGraph::compile.
// validate_and_schedule: every check, culling, the order, and scratch.last_pass.
void validate_and_schedule(const GraphData& graph, CompiledState& state, std::vector<GraphError>& errors);
// One walk over the order: lifetimes, transient memory (aliasing) and barriers. `replan` is
// for a compiled graph whose order and lifetimes are known (execute() sizing memory with its
// device's requirements); otherwise validate_and_schedule() has just run.
void plan_frame(const GraphData& graph, CompiledState& state, const gpu::Device* device, bool replan,
                std::vector<GraphError>& errors);

// Estimated memory requirements when no device is at hand.
gpu::MemoryRequirements estimate_requirements(const ResourceInfo& resource);

std::string format_extent(gpu::Extent3D extent);

}  // namespace weft::detail

// ---- setup's fast paths ----------------------------------------------------------------
// Inline, because a frame's setup runs them for every declaration. The common case -- a
// valid handle at its latest version, the pass's first use of that resource -- is decided
// here in a few comparisons; merging a second declaration and every mistake go to
// builder.cpp, which reports them.
namespace weft::detail {

inline constexpr std::uint16_t attachment_use_bits =
    use_bit(TextureUse::ColorAttachment) | use_bit(TextureUse::DepthAttachment) | use_bit(TextureUse::DepthRead);

[[gnu::cold]] void report_nested_pass(GraphData& g, std::string_view name);
[[gnu::cold]] void report_texture_desc(GraphData& g, std::uint32_t resource, const TextureDesc& desc,
                                       std::string_view pass_name);
std::uint32_t declare_slow(GraphData& g, std::uint32_t pass, ResourceType type, std::uint32_t resource,
                           std::uint32_t version, std::uint16_t use, bool write, gpu::Access access,
                           bool wrong_direction);

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

inline PassBuilder begin_pass(GraphData& g, std::string_view name, const ErasedExecute& execute) {
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
  return PassBuilder(&g, index);
}

inline void end_pass(GraphData& g, std::uint32_t pass) {
  g.passes[pass].access_count = std::uint32_t(g.accesses.size()) - g.passes[pass].first_access;
  g.current_pass = invalid_index;
}

inline std::uint32_t builder_pass(const PassBuilder& builder) { return builder.pass_; }

}  // namespace weft::detail

namespace weft {

[[gnu::always_inline]] inline TextureHandle PassBuilder::create_texture(std::string_view name, const TextureDesc& desc) {
  const std::uint32_t index = detail::add_resource(*graph_, name, ResourceType::Texture, pass_);
  detail::set_texture_desc(graph_->resources[index].texture_desc, desc);
  const gpu::Extent3D& e = desc.size.absolute;
  const bool valid = desc.format != gpu::Format::Undefined && desc.mip_level_count != 0 &&
                     (desc.size.is_relative ? desc.size.relative.width > 0.0f && desc.size.relative.height > 0.0f
                                            : e.width != 0 && e.height != 0 && e.depth_or_layers != 0);
  if (!valid) [[unlikely]]
    detail::report_texture_desc(*graph_, index, desc, graph_->passes[pass_].name);
  return {index, 0};
}

[[gnu::always_inline]] inline TextureHandle PassBuilder::read(TextureHandle handle, TextureUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Texture, handle.index, handle.version,
                                        detail::use_bit(use), false, access_of(use), is_write(use))};
}
[[gnu::always_inline]] inline BufferHandle PassBuilder::read(BufferHandle handle, BufferUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Buffer, handle.index, handle.version,
                                        detail::use_bit(use), false, access_of(use), is_write(use))};
}
[[gnu::always_inline]] inline TextureHandle PassBuilder::write(TextureHandle handle, TextureUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Texture, handle.index, handle.version,
                                        detail::use_bit(use), true, access_of(use), !is_write(use))};
}
[[gnu::always_inline]] inline BufferHandle PassBuilder::write(BufferHandle handle, BufferUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Buffer, handle.index, handle.version,
                                        detail::use_bit(use), true, access_of(use), !is_write(use))};
}

}  // namespace weft
