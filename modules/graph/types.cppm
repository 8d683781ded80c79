// weft.graph:types — the words the graph's API is made of: resource handles, the uses a pass
// declares, descriptors, errors, compile and execute options, and what a compiled graph
// reports about its passes, resources, memory and barriers. All of it is exported.
module;
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>
export module weft.graph:types;
import weft.core;
import weft.gpu;

export namespace weft {

inline constexpr std::uint32_t invalid_index = ~0u;

// Subresources: mips and layers of a texture a pass uses apart from the rest (see
// PassBuilder::read/write with a range). The default range is the whole texture.
using TextureRange = gpu::TextureRange;

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
  // MSAA: a multisampled texture is an attachment (every multisampled attachment of a pass
  // has the same count) and is read through a single-sample resolve target a render pass
  // writes beside it (gpu::ColorAttachment::resolve_target), never sampled directly.
  std::uint32_t sample_count = 1;
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
  SampleCount,                // multisampled attachments that differ, or a multisampled texture read per texel
  Memory,                     // the device refused to size or place a transient resource
  DuplicateName,              // two passes, or two resources, declared with one name
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
  // Submit and wait after every pass, timing each on the wall clock (PassStats::wall_ms).
  // For profiling on CPU adapters: lavapipe takes a timestamp when its rasteriser reaches
  // it, after the vertex shading, clipping and binning of the pass's draws, so GPU spans
  // there leave out all of a pass's geometry work. A serial frame costs more than a normal
  // one (no overlap between passes), so time frames with it off.
  bool serial_passes = false;
};

struct PassStats {
  std::string name;
  PassKind kind = PassKind::Compute;
  double gpu_ms = -1.0;        // -1 when timestamps are off or unsupported
  double cpu_record_us = 0.0;  // time spent in the pass's execute callback
  double wall_ms = -1.0;       // ExecuteOptions::serial_passes: record + submit + wait of this pass alone
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
  std::uint32_t sample_count = 1;
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
// `range` is the subresources the barrier moves: of `resource`, or -- with previous_occupant
// set -- of the occupant (a resource taking memory over starts whole, from Undefined; an
// occupant whose mips or layers were left in different states moves part by part).
struct PlannedBarrier {
  std::uint32_t resource = invalid_index;
  gpu::Access before = gpu::Access::Undefined;
  gpu::Access after = gpu::Access::Undefined;
  std::uint32_t previous_occupant = invalid_index;
  gpu::Access occupant_before = gpu::Access::Undefined;
  gpu::Access occupant_after = gpu::Access::Undefined;
  TextureRange range{};
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
