// weft.gpu — a wgpu-shaped API over Vulkan 1.3: descriptors in, move-only handles out,
// misuse returned as an Error naming the object's label. The only module that includes
// vulkan.h; passes, the graph and the renderer see just these types.
module;
#include <array>
#include <atomic>
#include <cstddef>
#include <expected>
#include <utility>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>
#include <vulkan/vulkan.h>
export module weft.gpu;
import weft.core;

export namespace weft::gpu {

// ---- flags ---------------------------------------------------------------------------
template <class E>
struct EnableFlags : std::false_type {};
template <class E>
concept FlagEnum = EnableFlags<E>::value;
template <FlagEnum E>
constexpr E operator|(E a, E b) { return E(std::uint32_t(a) | std::uint32_t(b)); }
template <FlagEnum E>
constexpr E operator&(E a, E b) { return E(std::uint32_t(a) & std::uint32_t(b)); }
template <FlagEnum E>
constexpr bool has(E set, E bit) { return (std::uint32_t(set) & std::uint32_t(bit)) == std::uint32_t(bit); }
template <FlagEnum E>
constexpr bool any(E set) { return std::uint32_t(set) != 0; }

enum class BufferUsage : std::uint32_t {
  None = 0, MapRead = 1, MapWrite = 2, CopySrc = 4, CopyDst = 8, Index = 16, Vertex = 32,
  Uniform = 64, Storage = 128, Indirect = 256,
};
enum class TextureUsage : std::uint32_t {
  None = 0, CopySrc = 1, CopyDst = 2, Sampled = 4, Storage = 8, ColorAttachment = 16,
  DepthAttachment = 32,
};
enum class ShaderStage : std::uint32_t { None = 0, Vertex = 1, Fragment = 2, Compute = 4, All = 7 };
template <> struct EnableFlags<BufferUsage> : std::true_type {};
template <> struct EnableFlags<TextureUsage> : std::true_type {};
template <> struct EnableFlags<ShaderStage> : std::true_type {};

std::string to_string(BufferUsage usage);
std::string to_string(TextureUsage usage);

// ---- formats -------------------------------------------------------------------------
enum class Format : std::uint8_t {
  Undefined, R8Unorm, RG8Unorm, RGBA8Unorm, RGBA8Srgb, BGRA8Unorm, R16Float, RG16Float,
  RGBA16Float, R32Float, RG32Float, RGBA32Float, R32Uint, RGBA32Uint, Depth16Unorm,
  Depth32Float, Depth24PlusStencil8,
};
struct FormatInfo {
  std::string_view name;
  std::uint32_t bytes_per_texel = 0;
  std::uint32_t components = 0;
  bool depth = false;
  bool srgb = false;
  bool storage = false;  // usable as a storage image on every Vulkan 1.3 device
};
const FormatInfo& format_info(Format format);
inline std::string_view to_string(Format f) { return format_info(f).name; }
// Usages `format` can never take, named for error messages (empty when all are fine).
std::string forbidden_usages(Format format, TextureUsage usage);

enum class VertexFormat : std::uint8_t { Float32, Float32x2, Float32x3, Float32x4, Uint32, Unorm8x4 };

// ---- access states -------------------------------------------------------------------
// What a command does to a resource; barriers convert one state into the next. The
// graph derives these from declared usages; standalone code passes them by hand.
enum class Access : std::uint8_t {
  Undefined,       // contents may be discarded
  CopySrc, CopyDst,
  VertexBuffer, IndexBuffer, IndirectBuffer, UniformRead,
  ShaderRead,      // sampled texture or read-only storage buffer, any shader stage
  StorageRead, StorageWrite,  // storage image/buffer; StorageWrite covers read-write
  ColorAttachment, DepthAttachment, DepthRead,
  HostRead, HostWrite,
  Present,         // a surface texture handed to the window system (Surface::present)
};
std::string_view to_string(Access access);
constexpr bool is_write(Access a) {
  return a == Access::CopyDst || a == Access::StorageWrite || a == Access::ColorAttachment ||
         a == Access::DepthAttachment || a == Access::HostWrite;
}

struct Extent3D {
  std::uint32_t width = 1, height = 1, depth_or_layers = 1;
  friend bool operator==(const Extent3D&, const Extent3D&) = default;
};

// A block of a texture's subresources: mips [base_mip, base_mip + mip_count) of layers
// [base_layer, base_layer + layer_count) (a cube's faces are its six layers); a count of
// `remaining` runs to the last mip or layer, so the default range is the whole texture.
// Vulkan's VkImageSubresourceRange and wgpu's ImageSubresourceRange, without the aspect.
struct TextureRange {
  static constexpr std::uint32_t remaining = ~0u;
  std::uint32_t base_mip = 0, mip_count = remaining;
  std::uint32_t base_layer = 0, layer_count = remaining;

  static constexpr TextureRange whole() { return {}; }
  static constexpr TextureRange mip(std::uint32_t m) { return {m, 1, 0, remaining}; }
  static constexpr TextureRange mips(std::uint32_t base, std::uint32_t count) { return {base, count, 0, remaining}; }
  static constexpr TextureRange layer(std::uint32_t l) { return {0, remaining, l, 1}; }
  static constexpr TextureRange layers(std::uint32_t base, std::uint32_t count) { return {0, remaining, base, count}; }
  // One mip of one layer (a face of a cube's mip).
  static constexpr TextureRange at(std::uint32_t mip, std::uint32_t layer) { return {mip, 1, layer, 1}; }
  // The counts with `remaining` replaced, for a texture of `mips` mips and `layers` layers.
  [[nodiscard]] constexpr std::uint32_t mips_of(std::uint32_t mips) const {
    return mip_count == remaining ? (base_mip < mips ? mips - base_mip : 0) : mip_count;
  }
  [[nodiscard]] constexpr std::uint32_t layers_of(std::uint32_t layers) const {
    return layer_count == remaining ? (base_layer < layers ? layers - base_layer : 0) : layer_count;
  }
  // Whether the range names at least one subresource and none past the texture's last.
  [[nodiscard]] constexpr bool fits(std::uint32_t mips, std::uint32_t layers) const {
    const std::uint64_t m = mips_of(mips), l = layers_of(layers);
    return m > 0 && l > 0 && base_mip + m <= mips && base_layer + l <= layers;
  }
  [[nodiscard]] constexpr bool covers(std::uint32_t mips, std::uint32_t layers) const {
    return base_mip == 0 && base_layer == 0 && mips_of(mips) >= mips && layers_of(layers) >= layers;
  }
  friend constexpr bool operator==(const TextureRange&, const TextureRange&) = default;
};
// "mip 1", "mips 1-3 of layer 2", "the whole texture" (for errors); given the texture's
// counts, a range over all its layers (or mips) says so by leaving them out.
std::string describe(const TextureRange& range);
std::string describe(const TextureRange& range, std::uint32_t mips, std::uint32_t layers);

// ---- adapter -------------------------------------------------------------------------
enum class AdapterType : std::uint8_t { DiscreteGpu, IntegratedGpu, VirtualGpu, Cpu, Other };
std::string_view to_string(AdapterType type);

struct Limits {
  std::uint32_t max_texture_dimension_2d = 0;
  std::uint32_t max_push_constant_size = 0;
  std::uint32_t max_bound_descriptor_sets = 0;
  std::array<std::uint32_t, 3> max_compute_workgroup_size{};
  std::uint32_t max_compute_invocations = 0;
  std::uint64_t max_storage_buffer_range = 0;
  std::uint64_t min_uniform_buffer_offset_alignment = 0;
  std::uint64_t min_storage_buffer_offset_alignment = 0;
  double timestamp_period_ns = 0.0;
  bool timestamps = false;
  std::uint32_t max_compute_shared_memory = 0;  // bytes of workgroup-shared memory
  // Multisampling: the sample counts (bit c set: c samples) a texture can render with
  // (framebuffer*SampleCounts) and be sampled with (sampledImage*SampleCounts), colour and
  // depth; the depth resolve modes (ResolveMode bits); 1 everywhere on a device without MSAA.
  std::uint32_t color_sample_counts = 1, depth_sample_counts = 1;
  std::uint32_t sampled_color_sample_counts = 1, sampled_depth_sample_counts = 1;
  std::uint32_t depth_resolve_modes = 1;
  // The largest sampler anisotropy (maxSamplerAnisotropy); 1 where samplerAnisotropy is absent.
  float max_sampler_anisotropy = 1.0f;
};

// "1, 2, 4" for a mask of sample counts (Limits::color_sample_counts and friends).
std::string sample_counts_text(std::uint32_t counts);
// The largest count of a mask (e.g. 4 for lavapipe's 1 | 4).
std::uint32_t max_sample_count(std::uint32_t counts);

// Optional capabilities a pass may choose a path by (detected, not enabled: a pass that uses
// one asks the device for it).
struct AdapterFeatures {
  // VK_KHR_cooperative_matrix with its cooperativeMatrix feature: subgroup-wide matrix
  // multiply-add (tensor cores and the like). Lavapipe (Mesa 25) reports it too.
  bool cooperative_matrix = false;
  // sampleRateShading: a fragment shader may run once per sample (GLSL's `sample` inputs),
  // which weft's devices then enable.
  bool sample_rate_shading = false;
};

struct AdapterInfo {
  std::string name;
  std::string driver;
  std::string driver_info;
  AdapterType type = AdapterType::Other;
  std::uint32_t api_version = 0;  // VK_MAKE_API_VERSION packing
  std::uint64_t device_local_bytes = 0;
  Limits limits;
  AdapterFeatures features;
  [[nodiscard]] std::string api_version_string() const;
};

enum class PowerPreference : std::uint8_t { HighPerformance, Cpu };
struct AdapterOptions {
  PowerPreference preference = PowerPreference::HighPerformance;
  // Picks the first adapter whose name contains this (case-insensitive), if set.
  // The environment variable WEFT_ADAPTER overrides both ("cpu", "gpu" or a name).
  std::string name_contains;
};

struct InstanceDescriptor {
  std::string application_name = "weft";
  bool validation = false;              // VK_LAYER_KHRONOS_validation; also WEFT_VALIDATION=1
  bool synchronization_validation = false;
  // Enables the window-system extensions (VK_KHR_surface, VK_KHR_xlib_surface) so that
  // create_surface works; devices of such an instance enable VK_KHR_swapchain. Off by
  // default: headless rendering needs no display.
  bool presentation = false;
};

class Surface;
// A window the platform layer owns, named by its native handles (X11 through Xlib: a
// `Display*` and a `Window`), so that no windowing library reaches this module.
struct NativeWindow {
  void* x11_display = nullptr;
  std::uint64_t x11_window = 0;
};

class Adapter;
class Device;

namespace detail {
struct InstanceShared;
struct DeviceShared;
struct Allocation;
}  // namespace detail

class Instance {
 public:
  static Result<Instance> create(const InstanceDescriptor& desc = {});
  Instance(Instance&&) noexcept;
  Instance& operator=(Instance&&) noexcept;
  ~Instance();

  [[nodiscard]] std::vector<AdapterInfo> enumerate_adapters() const;
  Result<Adapter> request_adapter(const AdapterOptions& options = {}) const;
  // A surface for `window` (needs InstanceDescriptor::presentation).
  Result<Surface> create_surface(const NativeWindow& window) const;
  [[nodiscard]] bool presentation_enabled() const;

  // Warnings and errors reported by the validation layer since the last call.
  [[nodiscard]] std::vector<std::string> take_validation_messages() const;
  [[nodiscard]] std::size_t validation_message_count() const;
  [[nodiscard]] bool validation_enabled() const;

 private:
  explicit Instance(std::shared_ptr<detail::InstanceShared> s) : shared_(std::move(s)) {}
  std::shared_ptr<detail::InstanceShared> shared_;
  friend class Adapter;
};

struct DeviceDescriptor {
  std::string label = "device";
};

class Adapter {
 public:
  [[nodiscard]] const AdapterInfo& info() const { return info_; }
  Result<Device> request_device(const DeviceDescriptor& desc = {}) const;

 private:
  Adapter(std::shared_ptr<detail::InstanceShared> s, VkPhysicalDevice pd, AdapterInfo info)
      : shared_(std::move(s)), physical_(pd), info_(std::move(info)) {}
  std::shared_ptr<detail::InstanceShared> shared_;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  AdapterInfo info_;
  friend class Instance;
};

// ---- resources -----------------------------------------------------------------------
// A block of device memory that resources can be placed into at chosen offsets; the
// graph aliases transient resources this way. allocate()/release() is a first-fit
// sub-allocator for callers that do not want to choose offsets themselves.
class MemoryBlock {
 public:
  MemoryBlock(MemoryBlock&&) noexcept;
  MemoryBlock& operator=(MemoryBlock&&) noexcept;
  ~MemoryBlock();
  [[nodiscard]] std::uint64_t size() const { return size_; }
  [[nodiscard]] const std::string& label() const { return label_; }
  std::optional<std::uint64_t> allocate(std::uint64_t size, std::uint64_t alignment);
  void release(std::uint64_t offset);

 private:
  MemoryBlock() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  std::uint64_t size_ = 0;
  std::uint32_t type_index_ = 0;
  std::string label_;
  std::map<std::uint64_t, std::uint64_t> free_;  // offset -> size
  std::map<std::uint64_t, std::uint64_t> used_;
  friend class Device;
  friend struct detail::DeviceShared;
};

struct Placement {
  const MemoryBlock* block = nullptr;
  std::uint64_t offset = 0;
};

struct MemoryRequirements {
  std::uint64_t size = 0;
  std::uint64_t alignment = 1;
  std::uint32_t type_bits = 0;
};

struct BufferDescriptor {
  std::string label;
  std::uint64_t size = 0;
  BufferUsage usage = BufferUsage::None;
};

class Buffer {
 public:
  Buffer(Buffer&&) noexcept;
  Buffer& operator=(Buffer&&) noexcept;
  ~Buffer();
  [[nodiscard]] std::uint64_t size() const { return size_; }
  [[nodiscard]] BufferUsage usage() const { return usage_; }
  [[nodiscard]] const std::string& label() const { return label_; }
  // Host view of a MapRead/MapWrite buffer (persistently mapped, coherent). Read it only
  // after the queue has finished the work that wrote it.
  Result<std::span<std::byte>> mapped() const;

 private:
  Buffer() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  std::unique_ptr<detail::Allocation> allocation_;
  std::byte* mapped_ = nullptr;
  std::uint64_t size_ = 0;
  BufferUsage usage_ = BufferUsage::None;
  std::string label_;
  friend class Device;
  friend class Queue;
  friend class CommandEncoder;
  friend class RenderPassEncoder;
  friend class ComputePassEncoder;
  friend struct detail::DeviceShared;
};

enum class TextureDimension : std::uint8_t { D2, D2Array, Cube, D3 };

struct TextureDescriptor {
  std::string label;
  Extent3D size;
  Format format = Format::RGBA8Unorm;
  TextureUsage usage = TextureUsage::None;
  std::uint32_t mip_level_count = 1;
  TextureDimension dimension = TextureDimension::D2;
  // 1, or a count the adapter renders this format with (Limits::color_sample_counts,
  // depth_sample_counts): a multisampled texture has one mip, is 2D, and is resolved
  // (ColorAttachment::resolve_target) before it is copied or sampled as one value per texel.
  std::uint32_t sample_count = 1;
};

class Texture;
class TextureView {
 public:
  TextureView(TextureView&&) noexcept;
  TextureView& operator=(TextureView&&) noexcept;
  ~TextureView();
  [[nodiscard]] const Texture& texture() const { return *texture_; }
  [[nodiscard]] std::uint32_t base_mip() const { return base_mip_; }
  [[nodiscard]] std::uint32_t mip_count() const { return mip_count_; }
  [[nodiscard]] std::uint32_t base_layer() const { return base_layer_; }
  [[nodiscard]] std::uint32_t layer_count() const { return layer_count_; }

 private:
  TextureView() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkImageView view_ = VK_NULL_HANDLE;
  const Texture* texture_ = nullptr;
  std::uint32_t base_mip_ = 0, mip_count_ = 1;
  std::uint32_t base_layer_ = 0, layer_count_ = 1;
  friend class Device;
  friend class Texture;
  friend class RenderPassEncoder;
  friend class CommandEncoder;
};

// A view of mips [base_mip, base_mip + mip_count) of layers [base_layer, base_layer +
// layer_count). Its type follows from the layers it sees: one layer of an array or a cube is
// a 2D view (a face to render into), several an array, all six of a cube a cube.
struct TextureViewDescriptor {
  std::uint32_t base_mip = 0;
  std::uint32_t mip_count = 1;
  std::uint32_t base_layer = 0;
  std::uint32_t layer_count = TextureRange::remaining;
};

class Texture {
 public:
  Texture(Texture&&) noexcept;
  Texture& operator=(Texture&&) noexcept;
  ~Texture();
  [[nodiscard]] const TextureDescriptor& descriptor() const { return desc_; }
  [[nodiscard]] const std::string& label() const { return desc_.label; }
  [[nodiscard]] Extent3D size() const { return desc_.size; }
  [[nodiscard]] Format format() const { return desc_.format; }
  [[nodiscard]] TextureUsage usage() const { return desc_.usage; }
  [[nodiscard]] std::uint32_t sample_count() const { return desc_.sample_count; }
  [[nodiscard]] std::uint32_t layer_count() const {
    return desc_.dimension == TextureDimension::D3 ? 1 : desc_.size.depth_or_layers;
  }
  // The view of every mip and layer, created with the texture (an empty view when the
  // texture can only be copied: Vulkan allows no views of such images).
  [[nodiscard]] const TextureView& view() const { return *default_view_; }
  Result<TextureView> create_view(const TextureViewDescriptor& desc) const;
  // The state the last recorded barrier left it in (for CommandEncoder::transition); after
  // barriers on parts of it (TextureBarrier::range), the last one's.
  [[nodiscard]] Access state() const { return state_; }
  // Overrides the tracked state, e.g. after recorded work was abandoned without submitting.
  void assume_state(Access state) const { state_ = state; }

 private:
  Texture() = default;
  void fix_view_back_pointer();
  std::shared_ptr<detail::DeviceShared> device_;
  VkImage image_ = VK_NULL_HANDLE;
  std::unique_ptr<detail::Allocation> allocation_;
  std::unique_ptr<TextureView> default_view_;
  TextureDescriptor desc_;
  mutable Access state_ = Access::Undefined;
  bool owns_image_ = true;  // false for a swapchain's images (the swapchain owns them)
  friend class Device;
  friend class Queue;
  friend class CommandEncoder;
  friend class RenderPassEncoder;
  friend class Surface;
};

enum class FilterMode : std::uint8_t { Nearest, Linear };
enum class AddressMode : std::uint8_t { ClampToEdge, Repeat, MirrorRepeat };
enum class CompareFunction : std::uint8_t { Never, Less, LessEqual, Greater, GreaterEqual, Equal, NotEqual, Always };

struct SamplerDescriptor {
  std::string label;
  FilterMode mag_filter = FilterMode::Linear;
  FilterMode min_filter = FilterMode::Linear;
  FilterMode mipmap_filter = FilterMode::Linear;
  AddressMode address_mode = AddressMode::ClampToEdge;
  std::optional<AddressMode> address_mode_v;  // v (and w) when it differs from u (glTF's wrapT)
  std::optional<CompareFunction> compare;  // set for shadow-map (comparison) samplers
  float max_lod = 32.0f;
  // Anisotropic filtering: 1 is off; above 1, up to this many taps along the footprint's
  // long axis, clamped to Limits::max_sampler_anisotropy (wgpu's anisotropy_clamp). Needs
  // linear filters.
  float max_anisotropy = 1.0f;
};

class Sampler {
 public:
  Sampler(Sampler&&) noexcept;
  Sampler& operator=(Sampler&&) noexcept;
  ~Sampler();
  [[nodiscard]] const std::string& label() const { return label_; }
  [[nodiscard]] bool is_comparison() const { return comparison_; }

 private:
  Sampler() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkSampler sampler_ = VK_NULL_HANDLE;
  std::string label_;
  bool comparison_ = false;
  friend class Device;
};

class QuerySet {
 public:
  QuerySet(QuerySet&&) noexcept;
  QuerySet& operator=(QuerySet&&) noexcept;
  ~QuerySet();
  [[nodiscard]] std::uint32_t count() const { return count_; }
  [[nodiscard]] const std::string& label() const { return label_; }
  // Timestamps in nanoseconds for queries [first, first + n); waits for availability.
  Result<std::vector<double>> read_timestamps_ns(std::uint32_t first, std::uint32_t n) const;

 private:
  QuerySet() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  std::uint32_t count_ = 0;
  std::string label_;
  friend class Device;
  friend class CommandEncoder;
};

// ---- shaders -------------------------------------------------------------------------
struct ShaderDefine {
  std::string name;
  std::string value = "1";
};

// GLSL compiled at run time (cached in memory and on disk, keyed by the preprocessed
// source) or SPIR-V compiled at build time for built-in passes.
struct ShaderModuleDescriptor {
  std::string label;
  ShaderStage stage = ShaderStage::Compute;
  std::string glsl;                          // source text, or
  std::filesystem::path path;                // a .glsl/.vert/.frag/.comp file, or
  std::span<const std::uint32_t> spirv;      // precompiled SPIR-V
  std::vector<std::filesystem::path> include_dirs;
  std::vector<ShaderDefine> defines;
};

// Compiles GLSL to SPIR-V without a device (used by ShaderModule and by tools).
Result<std::vector<std::uint32_t>> compile_glsl(const ShaderModuleDescriptor& desc);
struct ShaderCacheStats {
  std::uint64_t memory_hits = 0, disk_hits = 0, compiles = 0;
};
ShaderCacheStats shader_cache_stats();

class ShaderModule {
 public:
  ShaderModule(ShaderModule&&) noexcept;
  ShaderModule& operator=(ShaderModule&&) noexcept;
  ~ShaderModule();
  [[nodiscard]] ShaderStage stage() const { return stage_; }
  [[nodiscard]] const std::string& label() const { return label_; }

 private:
  ShaderModule() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkShaderModule module_ = VK_NULL_HANDLE;
  ShaderStage stage_ = ShaderStage::None;
  std::string label_;
  friend class Device;
};

// ---- binding -------------------------------------------------------------------------
enum class BindingType : std::uint8_t {
  UniformBuffer, StorageBuffer, ReadOnlyStorageBuffer,
  SampledTexture,   // texture2D, paired with a Sampler binding in GLSL
  TextureSampler,   // combined sampler2D
  StorageTexture,   // image2D
  Sampler,
};
std::string_view to_string(BindingType type);

struct BindGroupLayoutEntry {
  std::uint32_t binding = 0;
  BindingType type = BindingType::UniformBuffer;
  ShaderStage visibility = ShaderStage::All;
  Format storage_format = Format::Undefined;  // for StorageTexture
};

struct BindGroupLayoutDescriptor {
  std::string label;
  std::vector<BindGroupLayoutEntry> entries;
};

class BindGroupLayout {
 public:
  BindGroupLayout(BindGroupLayout&&) noexcept;
  BindGroupLayout& operator=(BindGroupLayout&&) noexcept;
  ~BindGroupLayout();
  [[nodiscard]] const BindGroupLayoutDescriptor& descriptor() const { return desc_; }
  [[nodiscard]] const std::string& label() const { return desc_.label; }

 private:
  BindGroupLayout() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkDescriptorSetLayout layout_ = VK_NULL_HANDLE;
  BindGroupLayoutDescriptor desc_;
  friend class Device;
};

struct BindGroupEntry {
  std::uint32_t binding = 0;
  const Buffer* buffer = nullptr;
  std::uint64_t offset = 0;
  std::uint64_t size = 0;  // 0 = to the end
  const TextureView* texture = nullptr;
  const Sampler* sampler = nullptr;
};
// Shorthands: bind(0, buffer), bind(1, texture.view(), &sampler), bind(2, sampler).
BindGroupEntry bind(std::uint32_t binding, const Buffer& buffer, std::uint64_t offset = 0, std::uint64_t size = 0);
BindGroupEntry bind(std::uint32_t binding, const TextureView& view, const Sampler* sampler = nullptr);
BindGroupEntry bind(std::uint32_t binding, const Sampler& sampler);

struct BindGroupDescriptor {
  std::string label;
  const BindGroupLayout* layout = nullptr;
  std::vector<BindGroupEntry> entries;
};

class BindGroup {
 public:
  BindGroup(BindGroup&&) noexcept;
  BindGroup& operator=(BindGroup&&) noexcept;
  ~BindGroup();
  [[nodiscard]] const std::string& label() const { return label_; }

 private:
  BindGroup() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout layout_ = VK_NULL_HANDLE;
  std::string label_;
  friend class Device;
  friend class RenderPassEncoder;
  friend class ComputePassEncoder;
};

struct PipelineLayoutDescriptor {
  std::string label;
  std::vector<const BindGroupLayout*> bind_group_layouts;
  std::uint32_t push_constant_size = 0;  // bytes, visible to every stage
};

class PipelineLayout {
 public:
  PipelineLayout(PipelineLayout&&) noexcept;
  PipelineLayout& operator=(PipelineLayout&&) noexcept;
  ~PipelineLayout();
  [[nodiscard]] const std::string& label() const { return label_; }
  [[nodiscard]] std::uint32_t push_constant_size() const { return push_constant_size_; }

 private:
  PipelineLayout() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  std::vector<VkDescriptorSetLayout> set_layouts_;
  std::uint32_t push_constant_size_ = 0;
  std::string label_;
  friend class Device;
  friend class RenderPassEncoder;
  friend class ComputePassEncoder;
};

// ---- pipelines -----------------------------------------------------------------------
struct VertexAttribute {
  VertexFormat format = VertexFormat::Float32x3;
  std::uint32_t offset = 0;
  std::uint32_t location = 0;
};
enum class VertexStepMode : std::uint8_t { Vertex, Instance };
struct VertexBufferLayout {
  std::uint32_t stride = 0;
  VertexStepMode step_mode = VertexStepMode::Vertex;
  std::vector<VertexAttribute> attributes;
};

enum class PrimitiveTopology : std::uint8_t { TriangleList, TriangleStrip, LineList, PointList };
enum class CullMode : std::uint8_t { None, Front, Back };
enum class BlendMode : std::uint8_t { Replace, Alpha, PremultipliedAlpha, Additive };

struct ColorTargetState {
  Format format = Format::RGBA8Unorm;
  BlendMode blend = BlendMode::Replace;
};
struct DepthStencilState {
  Format format = Format::Depth32Float;
  bool depth_write = true;
  CompareFunction compare = CompareFunction::Less;
  float depth_bias_constant = 0.0f;  // shadow maps: push depth away to avoid acne
  float depth_bias_slope = 0.0f;
};

// How a pipeline rasterises into multisampled attachments (wgpu's MultisampleState).
struct MultisampleState {
  std::uint32_t count = 1;  // the attachments' sample count
  std::uint32_t mask = ~0u;  // samples that may be written
  // The fragment's alpha becomes its coverage (hair, foliage: alpha-tested edges that
  // anti-alias with MSAA instead of a hard discard). Needs count > 1.
  bool alpha_to_coverage = false;
};

struct RenderPipelineDescriptor {
  std::string label;
  const PipelineLayout* layout = nullptr;
  const ShaderModule* vertex = nullptr;
  const ShaderModule* fragment = nullptr;  // may be null for depth-only pipelines
  std::vector<VertexBufferLayout> vertex_buffers;
  PrimitiveTopology topology = PrimitiveTopology::TriangleList;
  CullMode cull_mode = CullMode::None;
  bool front_face_clockwise = false;
  std::vector<ColorTargetState> color_targets;
  std::optional<DepthStencilState> depth_stencil;
  MultisampleState multisample;
};

class RenderPipeline {
 public:
  RenderPipeline(RenderPipeline&&) noexcept;
  RenderPipeline& operator=(RenderPipeline&&) noexcept;
  ~RenderPipeline();
  [[nodiscard]] const std::string& label() const { return label_; }
  [[nodiscard]] std::uint32_t sample_count() const { return sample_count_; }

 private:
  RenderPipeline() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;  // the PipelineLayout must outlive the pipeline
  std::uint32_t push_constant_size_ = 0;
  std::vector<Format> color_formats_;
  Format depth_format_ = Format::Undefined;
  std::uint32_t sample_count_ = 1;
  std::string label_;
  friend class Device;
  friend class RenderPassEncoder;
};

struct ComputePipelineDescriptor {
  std::string label;
  const PipelineLayout* layout = nullptr;
  const ShaderModule* module = nullptr;
};

class ComputePipeline {
 public:
  ComputePipeline(ComputePipeline&&) noexcept;
  ComputePipeline& operator=(ComputePipeline&&) noexcept;
  ~ComputePipeline();
  [[nodiscard]] const std::string& label() const { return label_; }

 private:
  ComputePipeline() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;  // the PipelineLayout must outlive the pipeline
  std::uint32_t push_constant_size_ = 0;
  std::string label_;
  friend class Device;
  friend class ComputePassEncoder;
};

// ---- commands ------------------------------------------------------------------------
enum class LoadOp : std::uint8_t { Clear, Load, DontCare };
enum class StoreOp : std::uint8_t { Store, DontCare };

// How a multisampled depth attachment becomes one value per texel (VkResolveModeFlagBits'
// bits: Limits::depth_resolve_modes has bit 1 << mode). SampleZero is always there.
enum class ResolveMode : std::uint8_t { SampleZero, Average, Min, Max };
std::string_view to_string(ResolveMode mode);

struct ColorAttachment {
  const TextureView* view = nullptr;
  LoadOp load = LoadOp::Clear;
  StoreOp store = StoreOp::Store;
  vec4 clear_color{0.0f, 0.0f, 0.0f, 1.0f};
  // A multisampled `view` is averaged into this single-sample view of its format and size
  // when the pass ends (in ColorAttachment state); `store` may then be DontCare.
  const TextureView* resolve_target = nullptr;
};
struct DepthAttachment {
  const TextureView* view = nullptr;
  LoadOp load = LoadOp::Clear;
  StoreOp store = StoreOp::Store;
  float clear_depth = 1.0f;
  // Depth-tested but never written (texture in DepthRead state): loads, stores nothing,
  // and may be sampled by the same pass.
  bool read_only = false;
  // A multisampled `view` resolved into this single-sample depth view (in DepthAttachment
  // state) when the pass ends, by `resolve_mode` (which the adapter must have).
  const TextureView* resolve_target = nullptr;
  ResolveMode resolve_mode = ResolveMode::SampleZero;
};
struct RenderPassDescriptor {
  std::string label;
  std::vector<ColorAttachment> color_attachments;
  std::optional<DepthAttachment> depth_attachment;
};

class CommandBuffer {
 public:
  CommandBuffer(CommandBuffer&&) noexcept;
  CommandBuffer& operator=(CommandBuffer&&) noexcept;
  ~CommandBuffer();
  [[nodiscard]] const std::string& label() const { return label_; }

 private:
  CommandBuffer() = default;
  std::shared_ptr<detail::DeviceShared> device_;
  VkCommandPool pool_ = VK_NULL_HANDLE;  // the recording thread's pool, which cmd_ is freed to
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  std::string label_;
  friend class CommandEncoder;
  friend class Queue;
  friend class Surface;
};

class CommandEncoder;

// Records draws between CommandEncoder::begin_render_pass and end(). Errors are kept
// and reported by CommandEncoder::finish(), as in wgpu.
class RenderPassEncoder {
 public:
  RenderPassEncoder(RenderPassEncoder&&) noexcept;
  RenderPassEncoder& operator=(RenderPassEncoder&&) = delete;
  ~RenderPassEncoder();
  void set_pipeline(const RenderPipeline& pipeline);
  void set_bind_group(std::uint32_t index, const BindGroup& group);
  void set_vertex_buffer(std::uint32_t slot, const Buffer& buffer, std::uint64_t offset = 0);
  void set_index_buffer(const Buffer& buffer, std::uint64_t offset = 0);  // uint32 indices
  void set_push_constants(std::span<const std::byte> data, std::uint32_t offset = 0);
  template <class T>
  void push(const T& value) { set_push_constants(std::as_bytes(std::span(&value, 1))); }
  void set_viewport(float x, float y, float width, float height);
  // Draws only inside this rectangle (clamped to the attachment); the default is all of it.
  void set_scissor_rect(std::int32_t x, std::int32_t y, std::uint32_t width, std::uint32_t height);
  void draw(std::uint32_t vertex_count, std::uint32_t instance_count = 1, std::uint32_t first_vertex = 0,
            std::uint32_t first_instance = 0);
  void draw_indexed(std::uint32_t index_count, std::uint32_t instance_count = 1, std::uint32_t first_index = 0,
                    std::int32_t base_vertex = 0, std::uint32_t first_instance = 0);
  void end();

 private:
  explicit RenderPassEncoder(CommandEncoder* encoder) : encoder_(encoder) {}
  bool check_draw(std::string_view what);
  CommandEncoder* encoder_ = nullptr;
  const RenderPipeline* pipeline_ = nullptr;
  std::array<VkDescriptorSet, 8> groups_{};  // bound at the next draw with the pipeline's layout
  std::uint32_t dirty_groups_ = 0;
  bool index_bound_ = false;
  std::uint32_t width_ = 0, height_ = 0;
  std::vector<Format> color_formats_;
  Format depth_format_ = Format::Undefined;
  std::uint32_t sample_count_ = 1;
  std::string label_;
  bool ended_ = false;
  friend class CommandEncoder;
};

class ComputePassEncoder {
 public:
  ComputePassEncoder(ComputePassEncoder&&) noexcept;
  ComputePassEncoder& operator=(ComputePassEncoder&&) = delete;
  ~ComputePassEncoder();
  void set_pipeline(const ComputePipeline& pipeline);
  void set_bind_group(std::uint32_t index, const BindGroup& group);
  void set_push_constants(std::span<const std::byte> data, std::uint32_t offset = 0);
  template <class T>
  void push(const T& value) { set_push_constants(std::as_bytes(std::span(&value, 1))); }
  void dispatch(std::uint32_t x, std::uint32_t y = 1, std::uint32_t z = 1);
  // The group counts x, y, z (three uint32) at `offset` in `args`, written by earlier GPU work
  // (a list whose length only the GPU knows); a graph pass declares `args` BufferUse::Indirect.
  void dispatch_indirect(const Buffer& args, std::uint64_t offset = 0);
  void end();

 private:
  explicit ComputePassEncoder(CommandEncoder* encoder) : encoder_(encoder) {}
  bool ready_to_dispatch(std::string_view what);
  CommandEncoder* encoder_ = nullptr;
  const ComputePipeline* pipeline_ = nullptr;
  std::array<VkDescriptorSet, 8> groups_{};
  std::uint32_t dirty_groups_ = 0;
  std::string label_;
  bool ended_ = false;
  friend class CommandEncoder;
};

struct TextureBarrier {
  const Texture* texture = nullptr;
  Access before = Access::Undefined;
  Access after = Access::Undefined;
  TextureRange range{};  // the subresources it moves (default: all)
};
struct BufferBarrier {
  const Buffer* buffer = nullptr;
  Access before = Access::Undefined;
  Access after = Access::Undefined;
};

class CommandEncoder {
 public:
  CommandEncoder(CommandEncoder&&) noexcept;
  CommandEncoder& operator=(CommandEncoder&&) noexcept;
  ~CommandEncoder();

  RenderPassEncoder begin_render_pass(const RenderPassDescriptor& desc);
  ComputePassEncoder begin_compute_pass(std::string_view label = {});

  void copy_buffer_to_buffer(const Buffer& src, std::uint64_t src_offset, const Buffer& dst,
                             std::uint64_t dst_offset, std::uint64_t size);
  // Tight rows; the texture must be in CopyDst / CopySrc state (see barrier()).
  void copy_buffer_to_texture(const Buffer& src, std::uint64_t src_offset, const Texture& dst, std::uint32_t mip = 0);
  void copy_texture_to_buffer(const Texture& src, const Buffer& dst, std::uint64_t dst_offset, std::uint32_t mip = 0);
  void fill_buffer(const Buffer& buffer, std::uint32_t value, std::uint64_t offset = 0, std::uint64_t size = 0);
  // Scales all of `src` (CopySrc state) onto all of `dst` (CopyDst state), converting the
  // format (e.g. RGBA to a window's BGRA); linear or nearest filtering.
  void blit_texture(const Texture& src, const Texture& dst, FilterMode filter = FilterMode::Linear);
  // Scales mip `src_mip` of `src` onto mip `dst_mip` of `dst`, every layer: with src == dst
  // and two mips, a mip chain generated inside one texture (each mip in its own state).
  void blit_texture(const Texture& src, std::uint32_t src_mip, const Texture& dst, std::uint32_t dst_mip,
                    FilterMode filter = FilterMode::Linear);
  // Averages the samples of multisampled colour `src` (CopySrc state) into single-sample
  // `dst` (CopyDst state) of its format and size: a resolve as a transfer, which reads `src`
  // and writes nothing else (a render pass's resolve target stores its attachment too).
  void resolve_texture(const Texture& src, const Texture& dst);

  // Explicit barriers (what the graph emits), batched into one vkCmdPipelineBarrier2.
  void barrier(std::span<const TextureBarrier> textures, std::span<const BufferBarrier> buffers = {});
  // Convenience: from the texture's last recorded state to `after`.
  void transition(const Texture& texture, Access after);

  void reset_query_set(const QuerySet& set);
  void write_timestamp(const QuerySet& set, std::uint32_t index);
  void push_debug_group(std::string_view label);
  void pop_debug_group();

  // Records an error found while recording (e.g. by a pass's own validation); the first
  // one is what finish() returns.
  void report_error(Error error);

  // The first recorded error, naming the object and the encoder, or the command buffer.
  Result<CommandBuffer> finish();

 private:
  CommandEncoder() = default;
  bool check_outside_pass(std::string_view what);
  std::shared_ptr<detail::DeviceShared> device_;
  // The recording thread's pool (DeviceShared::thread_pool): a pool must not be used by two
  // threads at once, and two threads may record on one device (the viewer's window and
  // render threads). Record, submit and drop an encoder on the thread that made it.
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  std::string label_;
  std::optional<Error> error_;
  bool in_pass_ = false;
  friend class Device;
  friend class RenderPassEncoder;
  friend class ComputePassEncoder;
  friend struct detail::DeviceShared;
};

class Queue {
 public:
  // Submits and returns at once; wait_idle() (or any read-back) waits for completion.
  // Thread-safe: threads may share a device (each with its own encoders).
  Result<void> submit(CommandBuffer&& commands);
  // Waits for the work this thread submitted (and so for all work submitted before it: one
  // queue runs in order), not for what other threads submitted since.
  Result<void> wait_idle();
  // Writes through a staging buffer (or directly into a MapWrite buffer) and waits.
  Result<void> write_buffer(const Buffer& buffer, std::uint64_t offset, std::span<const std::byte> data);
  // Uploads tightly-packed texels to mip `mip` and leaves the texture in ShaderRead state.
  Result<void> write_texture(const Texture& texture, std::span<const std::byte> data, std::uint32_t mip = 0,
                             Access after = Access::ShaderRead);
  // Uploads mips 0..levels.size()-1 (each tightly packed) through one staging buffer in one
  // submission, and waits: a texture's mip chain (Texture::mip_level_count of them at most).
  Result<void> write_texture_levels(const Texture& texture, std::span<const std::span<const std::byte>> levels,
                                    Access after = Access::ShaderRead);
  // Copies a texture's mip back to the host (tightly packed) and waits. The texture must
  // have CopySrc usage; it is left in `after` state.
  Result<std::vector<std::byte>> read_texture(const Texture& texture, std::uint32_t mip = 0);
  Result<std::vector<std::byte>> read_buffer(const Buffer& buffer, std::uint64_t offset = 0, std::uint64_t size = 0);

 private:
  std::shared_ptr<detail::DeviceShared> device_;
  friend class Device;
  friend class Adapter;
};

class Device {
 public:
  // A device without an adapter, in the manner of wgpu's noop backend: create_* check their
  // descriptors as always and return objects that keep their descriptors (labels, sizes,
  // formats, usages) but own no driver object; queue writes are dropped. Recording,
  // submitting and reading back fail (Unsupported). It needs no Vulkan driver, so a frame
  // can be declared and compiled where there is none (Renderer::describe, `weft graph check`).
  static Device create_declaring(std::string label = "declaring");
  // True for a create_declaring() device: features skip bakes and uploads that only feed
  // the GPU (nothing would run), and the graph compiles without it.
  [[nodiscard]] bool declaring() const;

  Device(Device&&) noexcept;
  Device& operator=(Device&&) noexcept;
  ~Device();

  [[nodiscard]] const AdapterInfo& adapter_info() const;
  [[nodiscard]] Queue& queue() { return queue_; }

  Result<Buffer> create_buffer(const BufferDescriptor& desc, Placement placement = {});
  // A buffer holding `data`, uploaded before return.
  Result<Buffer> create_buffer_with_data(const BufferDescriptor& desc, std::span<const std::byte> data);
  Result<Texture> create_texture(const TextureDescriptor& desc, Placement placement = {});
  Result<Sampler> create_sampler(const SamplerDescriptor& desc = {});
  Result<ShaderModule> create_shader_module(const ShaderModuleDescriptor& desc);
  Result<BindGroupLayout> create_bind_group_layout(const BindGroupLayoutDescriptor& desc);
  Result<BindGroup> create_bind_group(const BindGroupDescriptor& desc);
  Result<PipelineLayout> create_pipeline_layout(const PipelineLayoutDescriptor& desc);
  Result<RenderPipeline> create_render_pipeline(const RenderPipelineDescriptor& desc);
  Result<ComputePipeline> create_compute_pipeline(const ComputePipelineDescriptor& desc);
  Result<QuerySet> create_query_set(std::string_view label, std::uint32_t count);
  Result<CommandEncoder> create_command_encoder(std::string_view label = "encoder");

  // Device-local memory that placed resources share (the graph's aliasing heap).
  Result<MemoryBlock> create_memory_block(std::string_view label, std::uint64_t size, std::uint32_t type_bits = ~0u);
  Result<MemoryRequirements> memory_requirements(const TextureDescriptor& desc) const;
  Result<MemoryRequirements> memory_requirements(const BufferDescriptor& desc) const;

  // Bytes of device memory currently allocated by this device (dedicated + blocks).
  [[nodiscard]] std::uint64_t allocated_bytes() const;

 private:
  Device() = default;
  std::shared_ptr<detail::DeviceShared> shared_;
  Queue queue_;
  friend class Adapter;
  friend class Surface;
};

// ---- presentation ----------------------------------------------------------------------
// wgpu's shape: configure(device, size, format, present mode), get_current_texture(),
// present(). The texture is an ordinary Texture (import it into a frame's graph and mark it
// an output in Access::Present); present() hands it to the window system.
enum class PresentMode : std::uint8_t { Fifo, Mailbox, Immediate };
std::string_view to_string(PresentMode mode);

struct SurfaceConfiguration {
  Format format = Format::BGRA8Unorm;
  TextureUsage usage = TextureUsage::ColorAttachment | TextureUsage::CopyDst | TextureUsage::CopySrc;
  std::uint32_t width = 0, height = 0;
  PresentMode present_mode = PresentMode::Fifo;  // falls back to Fifo where not supported
};

enum class SurfaceStatus : std::uint8_t {
  Good,
  Reconfigured,  // the window's size changed: the swapchain was remade at the new size
  Minimized,     // the window has no area (0x0): there is nothing to draw this frame
};

struct SurfaceTexture {
  const Texture* texture = nullptr;  // null when Minimized
  SurfaceStatus status = SurfaceStatus::Good;
};

struct SurfaceCapabilities {
  std::vector<Format> formats;            // the ones weft::gpu names
  std::vector<PresentMode> present_modes;
  TextureUsage usages = TextureUsage::None;
};

class Surface {
 public:
  Surface(Surface&&) noexcept;
  Surface& operator=(Surface&&) noexcept;
  ~Surface();
  // What this surface can do with `device`'s adapter; an error when its queue cannot present.
  Result<SurfaceCapabilities> capabilities(const Device& device) const;
  // (Re)creates the swapchain; a 0x0 size is allowed (a minimised window: nothing is made).
  Result<void> configure(Device& device, const SurfaceConfiguration& config);
  [[nodiscard]] const SurfaceConfiguration& configuration() const { return config_; }
  // The next texture to draw into. Out-of-date and suboptimal swapchains are remade at the
  // window's current size (status Reconfigured); a minimised window gives no texture.
  Result<SurfaceTexture> get_current_texture();
  // Shows the texture from get_current_texture(), moving it to Access::Present first when
  // the frame did not (e.g. it failed before drawing).
  Result<void> present();

 private:
  Surface() = default;
  struct State;
  std::unique_ptr<State> state_;
  SurfaceConfiguration config_;
  friend class Instance;
};

}  // namespace weft::gpu

// ---- internals shared by the implementation units (not exported) ----------------------
namespace weft::gpu::detail {

struct MessageLog;

struct InstanceShared {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  bool validation = false;
  bool debug_utils = false;
  bool presentation = false;  // VK_KHR_surface and the platform's surface extension are on
  std::shared_ptr<MessageLog> log;
  ~InstanceShared();
};

// A dedicated allocation or a placement inside a MemoryBlock (which owns the memory).
struct Allocation {
  std::shared_ptr<DeviceShared> device;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  std::uint64_t size = 0;
  bool owned = true;
  ~Allocation();
};

struct DeviceShared {
  std::shared_ptr<InstanceShared> instance;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t queue_family = 0;
  VkPhysicalDeviceMemoryProperties memory_properties{};
  AdapterInfo info;
  std::atomic<std::uint64_t> allocated_bytes = 0;
  bool swapchain = false;  // VK_KHR_swapchain is enabled
  // Submitted work not yet waited for, with the thread that submitted it. `mutex` guards it
  // and the VkQueue (submit, present), which Vulkan wants externally synchronised.
  struct Pending {
    VkFence fence;
    VkCommandPool pool;  // the submitted command buffer's
    VkCommandBuffer cmd;
    std::thread::id thread;
  };
  std::mutex mutex;
  std::vector<Pending> pending;
  std::map<std::thread::id, VkCommandPool> pools;  // one command pool per recording thread
  // A Device::create_declaring() device: no VkDevice, objects without driver handles.
  [[nodiscard]] bool declaring() const { return device == VK_NULL_HANDLE; }
  // The calling thread's command pool, made on first use.
  Result<VkCommandPool> thread_pool();
  // Submits one command buffer signalling `signal` (if any) and keeps it pending until the
  // thread waits; the buffer is freed then (or at once if the submit fails).
  Result<void> submit(VkCommandPool pool, VkCommandBuffer cmd, VkSemaphore signal, std::string_view label);
  ~DeviceShared();

  Result<std::uint32_t> find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                         VkMemoryPropertyFlags preferred) const;
  Result<std::unique_ptr<Allocation>> allocate(const VkMemoryRequirements& req, VkMemoryPropertyFlags required,
                                               VkMemoryPropertyFlags preferred, std::string_view label);
  void set_name(VkObjectType type, std::uint64_t handle, std::string_view name) const;
  Result<void> wait_idle();
  // Shared by Device and Queue (staging buffers, upload encoders).
  static Result<Buffer> make_buffer(const std::shared_ptr<DeviceShared>& self, const BufferDescriptor& desc,
                                    Placement placement);
  static Result<CommandEncoder> make_encoder(const std::shared_ptr<DeviceShared>& self, std::string_view label);
};

VkFormat to_vk(Format f);
VkFormat to_vk(VertexFormat f);
VkCompareOp to_vk(CompareFunction f);
VkBufferUsageFlags to_vk(BufferUsage u);
VkImageUsageFlags to_vk(TextureUsage u);
VkShaderStageFlags to_vk(ShaderStage s);
VkDescriptorType to_vk(BindingType t);
VkImageAspectFlags aspect_of(Format f);
struct StageAccess {
  VkPipelineStageFlags2 stages;
  VkAccessFlags2 access;
  VkImageLayout layout;
};
StageAccess stage_access(Access a, bool depth_format);
Error vk_error(VkResult result, std::string_view what);

}  // namespace weft::gpu::detail
