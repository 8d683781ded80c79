// Tables that translate weft.gpu's enums into Vulkan's, and name them for messages.
module;
#include <expected>
#include <optional>
#include <span>
#include <utility>
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vulkan/vulkan.h>
module weft.gpu;

namespace weft::gpu {

namespace {
struct FormatRow {
  FormatInfo info;
  VkFormat vk;
};
// clang-format off
constexpr std::array<FormatRow, 17> format_table{{
  {{"undefined", 0, 0, false, false, false}, VK_FORMAT_UNDEFINED},
  {{"r8unorm", 1, 1, false, false, true}, VK_FORMAT_R8_UNORM},
  {{"rg8unorm", 2, 2, false, false, true}, VK_FORMAT_R8G8_UNORM},
  {{"rgba8unorm", 4, 4, false, false, true}, VK_FORMAT_R8G8B8A8_UNORM},
  {{"rgba8unorm-srgb", 4, 4, false, true, false}, VK_FORMAT_R8G8B8A8_SRGB},
  {{"bgra8unorm", 4, 4, false, false, false}, VK_FORMAT_B8G8R8A8_UNORM},
  {{"r16float", 2, 1, false, false, true}, VK_FORMAT_R16_SFLOAT},
  {{"rg16float", 4, 2, false, false, true}, VK_FORMAT_R16G16_SFLOAT},
  {{"rgba16float", 8, 4, false, false, true}, VK_FORMAT_R16G16B16A16_SFLOAT},
  {{"r32float", 4, 1, false, false, true}, VK_FORMAT_R32_SFLOAT},
  {{"rg32float", 8, 2, false, false, true}, VK_FORMAT_R32G32_SFLOAT},
  {{"rgba32float", 16, 4, false, false, true}, VK_FORMAT_R32G32B32A32_SFLOAT},
  {{"r32uint", 4, 1, false, false, true}, VK_FORMAT_R32_UINT},
  {{"rgba32uint", 16, 4, false, false, true}, VK_FORMAT_R32G32B32A32_UINT},
  {{"depth16unorm", 2, 1, true, false, false}, VK_FORMAT_D16_UNORM},
  {{"depth32float", 4, 1, true, false, false}, VK_FORMAT_D32_SFLOAT},
  {{"depth24plus-stencil8", 4, 2, true, false, false}, VK_FORMAT_D24_UNORM_S8_UINT},
}};
// clang-format on

template <class E>
std::string flag_names(E value, std::initializer_list<std::pair<E, std::string_view>> names) {
  std::string out;
  for (auto [bit, name] : names) {
    if (has(value, bit)) {
      if (!out.empty()) out += '|';
      out += name;
    }
  }
  return out.empty() ? "none" : out;
}
}  // namespace

const FormatInfo& format_info(Format format) { return format_table[std::size_t(format)].info; }

std::string forbidden_usages(Format format, TextureUsage usage) {
  const FormatInfo& info = format_info(format);
  std::string out;
  auto add = [&](std::string_view what) {
    if (!out.empty()) out += ", ";
    out += what;
  };
  if (format == Format::Undefined) return "any usage (format undefined)";
  if (has(usage, TextureUsage::Storage) && !info.storage) add("storage");
  if (has(usage, TextureUsage::DepthAttachment) && !info.depth) add("depth-attachment");
  if (has(usage, TextureUsage::ColorAttachment) && info.depth) add("color-attachment");
  return out;
}

std::string to_string(BufferUsage u) {
  return flag_names(u, {{BufferUsage::MapRead, "map-read"}, {BufferUsage::MapWrite, "map-write"},
                        {BufferUsage::CopySrc, "copy-src"}, {BufferUsage::CopyDst, "copy-dst"},
                        {BufferUsage::Index, "index"}, {BufferUsage::Vertex, "vertex"},
                        {BufferUsage::Uniform, "uniform"}, {BufferUsage::Storage, "storage"},
                        {BufferUsage::Indirect, "indirect"}});
}

std::string to_string(TextureUsage u) {
  return flag_names(u, {{TextureUsage::CopySrc, "copy-src"}, {TextureUsage::CopyDst, "copy-dst"},
                        {TextureUsage::Sampled, "sampled"}, {TextureUsage::Storage, "storage"},
                        {TextureUsage::ColorAttachment, "color-attachment"},
                        {TextureUsage::DepthAttachment, "depth-attachment"}});
}

std::string sample_counts_text(std::uint32_t counts) {
  std::string text;
  for (std::uint32_t c = 1; c <= 64; c <<= 1)
    if (counts & c) text += (text.empty() ? "" : ", ") + std::to_string(c);
  return text.empty() ? std::string("none") : text;
}

std::uint32_t max_sample_count(std::uint32_t counts) {
  std::uint32_t best = 1;
  for (std::uint32_t c = 1; c <= 64; c <<= 1)
    if (counts & c) best = c;
  return best;
}

std::string_view to_string(ResolveMode mode) {
  switch (mode) {
    case ResolveMode::SampleZero: return "sample-zero";
    case ResolveMode::Average: return "average";
    case ResolveMode::Min: return "min";
    case ResolveMode::Max: return "max";
  }
  return "?";
}

std::string_view to_string(Access a) {
  switch (a) {
    case Access::Undefined: return "undefined";
    case Access::CopySrc: return "copy-src";
    case Access::CopyDst: return "copy-dst";
    case Access::VertexBuffer: return "vertex-buffer";
    case Access::IndexBuffer: return "index-buffer";
    case Access::IndirectBuffer: return "indirect-buffer";
    case Access::UniformRead: return "uniform-read";
    case Access::ShaderRead: return "shader-read";
    case Access::StorageRead: return "storage-read";
    case Access::StorageWrite: return "storage-write";
    case Access::ColorAttachment: return "color-attachment";
    case Access::DepthAttachment: return "depth-attachment";
    case Access::DepthRead: return "depth-read";
    case Access::HostRead: return "host-read";
    case Access::HostWrite: return "host-write";
    case Access::Present: return "present";
  }
  return "?";
}

std::string describe(const TextureRange& r) {
  auto span = [](const char* one, const char* many, std::uint32_t base, std::uint32_t count) {
    if (count == 1) return weft::format("{} {}", one, base);
    if (count == TextureRange::remaining) return base == 0 ? weft::format("every {}", one) : weft::format("{} {} on", many, base);
    return weft::format("{} {}-{}", many, base, base + count - 1);
  };
  if (r == TextureRange{}) return "the whole texture";
  const bool all_mips = r.base_mip == 0 && r.mip_count == TextureRange::remaining;
  const bool all_layers = r.base_layer == 0 && r.layer_count == TextureRange::remaining;
  if (all_layers) return span("mip", "mips", r.base_mip, r.mip_count);
  if (all_mips) return span("layer", "layers", r.base_layer, r.layer_count);
  return weft::format("{} of {}", span("mip", "mips", r.base_mip, r.mip_count),
                      span("layer", "layers", r.base_layer, r.layer_count));
}

std::string describe(const TextureRange& r, std::uint32_t mips, std::uint32_t layers) {
  TextureRange shown = r;
  if (r.base_mip == 0 && r.mips_of(mips) >= mips) shown.mip_count = TextureRange::remaining;
  if (r.base_layer == 0 && r.layers_of(layers) >= layers) shown.layer_count = TextureRange::remaining;
  return describe(shown);
}

std::string_view to_string(AdapterType t) {
  switch (t) {
    case AdapterType::DiscreteGpu: return "discrete GPU";
    case AdapterType::IntegratedGpu: return "integrated GPU";
    case AdapterType::VirtualGpu: return "virtual GPU";
    case AdapterType::Cpu: return "CPU";
    case AdapterType::Other: return "other";
  }
  return "?";
}

std::string_view to_string(BindingType t) {
  switch (t) {
    case BindingType::UniformBuffer: return "uniform buffer";
    case BindingType::StorageBuffer: return "storage buffer";
    case BindingType::ReadOnlyStorageBuffer: return "read-only storage buffer";
    case BindingType::SampledTexture: return "sampled texture";
    case BindingType::TextureSampler: return "texture+sampler";
    case BindingType::StorageTexture: return "storage texture";
    case BindingType::Sampler: return "sampler";
  }
  return "?";
}

std::string AdapterInfo::api_version_string() const {
  return weft::format("{}.{}.{}", VK_API_VERSION_MAJOR(api_version), VK_API_VERSION_MINOR(api_version),
                     VK_API_VERSION_PATCH(api_version));
}

}  // namespace weft::gpu

namespace weft::gpu::detail {

VkFormat to_vk(Format f) { return format_table[std::size_t(f)].vk; }

VkFormat to_vk(VertexFormat f) {
  switch (f) {
    case VertexFormat::Float32: return VK_FORMAT_R32_SFLOAT;
    case VertexFormat::Float32x2: return VK_FORMAT_R32G32_SFLOAT;
    case VertexFormat::Float32x3: return VK_FORMAT_R32G32B32_SFLOAT;
    case VertexFormat::Float32x4: return VK_FORMAT_R32G32B32A32_SFLOAT;
    case VertexFormat::Uint32: return VK_FORMAT_R32_UINT;
    case VertexFormat::Unorm8x4: return VK_FORMAT_R8G8B8A8_UNORM;
  }
  return VK_FORMAT_UNDEFINED;
}

VkCompareOp to_vk(CompareFunction f) {
  switch (f) {
    case CompareFunction::Never: return VK_COMPARE_OP_NEVER;
    case CompareFunction::Less: return VK_COMPARE_OP_LESS;
    case CompareFunction::LessEqual: return VK_COMPARE_OP_LESS_OR_EQUAL;
    case CompareFunction::Greater: return VK_COMPARE_OP_GREATER;
    case CompareFunction::GreaterEqual: return VK_COMPARE_OP_GREATER_OR_EQUAL;
    case CompareFunction::Equal: return VK_COMPARE_OP_EQUAL;
    case CompareFunction::NotEqual: return VK_COMPARE_OP_NOT_EQUAL;
    case CompareFunction::Always: return VK_COMPARE_OP_ALWAYS;
  }
  return VK_COMPARE_OP_ALWAYS;
}

VkBufferUsageFlags to_vk(BufferUsage u) {
  VkBufferUsageFlags f = 0;
  if (has(u, BufferUsage::CopySrc) || has(u, BufferUsage::MapWrite)) f |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  if (has(u, BufferUsage::CopyDst) || has(u, BufferUsage::MapRead)) f |= VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  if (has(u, BufferUsage::Index)) f |= VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
  if (has(u, BufferUsage::Vertex)) f |= VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
  if (has(u, BufferUsage::Uniform)) f |= VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT;
  if (has(u, BufferUsage::Storage)) f |= VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  if (has(u, BufferUsage::Indirect)) f |= VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
  return f;
}

VkImageUsageFlags to_vk(TextureUsage u) {
  VkImageUsageFlags f = 0;
  if (has(u, TextureUsage::CopySrc)) f |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  if (has(u, TextureUsage::CopyDst)) f |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  if (has(u, TextureUsage::Sampled)) f |= VK_IMAGE_USAGE_SAMPLED_BIT;
  if (has(u, TextureUsage::Storage)) f |= VK_IMAGE_USAGE_STORAGE_BIT;
  if (has(u, TextureUsage::ColorAttachment)) f |= VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  if (has(u, TextureUsage::DepthAttachment)) f |= VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  return f;
}

VkShaderStageFlags to_vk(ShaderStage s) {
  VkShaderStageFlags f = 0;
  if (has(s, ShaderStage::Vertex)) f |= VK_SHADER_STAGE_VERTEX_BIT;
  if (has(s, ShaderStage::Fragment)) f |= VK_SHADER_STAGE_FRAGMENT_BIT;
  if (has(s, ShaderStage::Compute)) f |= VK_SHADER_STAGE_COMPUTE_BIT;
  return f;
}

VkDescriptorType to_vk(BindingType t) {
  switch (t) {
    case BindingType::UniformBuffer: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case BindingType::StorageBuffer:
    case BindingType::ReadOnlyStorageBuffer: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case BindingType::SampledTexture: return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case BindingType::TextureSampler: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case BindingType::StorageTexture: return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    case BindingType::Sampler: return VK_DESCRIPTOR_TYPE_SAMPLER;
  }
  return VK_DESCRIPTOR_TYPE_MAX_ENUM;
}

VkImageAspectFlags aspect_of(Format f) {
  if (f == Format::Depth24PlusStencil8) return VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT;
  return format_info(f).depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

StageAccess stage_access(Access a, bool depth) {
  constexpr VkPipelineStageFlags2 shaders = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                                            VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                                            VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  constexpr VkPipelineStageFlags2 depth_stages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  switch (a) {
    case Access::Undefined: return {VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_IMAGE_LAYOUT_UNDEFINED};
    case Access::CopySrc:
      return {VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL};
    case Access::CopyDst:  // with the read: a buffer copied within itself is in this state (weft.graph)
      return {VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
              VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL};
    case Access::VertexBuffer:
      return {VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT, VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT,
              VK_IMAGE_LAYOUT_UNDEFINED};
    case Access::IndexBuffer:
      return {VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT, VK_ACCESS_2_INDEX_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED};
    case Access::IndirectBuffer:
      return {VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT,
              VK_IMAGE_LAYOUT_UNDEFINED};
    case Access::UniformRead: return {shaders, VK_ACCESS_2_UNIFORM_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED};
    case Access::ShaderRead:
      return {shaders, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
              depth ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    case Access::StorageRead: return {shaders, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_GENERAL};
    case Access::StorageWrite:
      return {shaders, VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
              VK_IMAGE_LAYOUT_GENERAL};
    case Access::ColorAttachment:
      return {VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
              VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
              VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    case Access::DepthAttachment:
      // Also the colour-output stage and accesses: a multisample resolve of depth into a
      // single-sample attachment reads and writes there, "whether the attachments being
      // resolved are color or depth/stencil" (the spec's render pass resolve section).
      return {depth_stages | VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
              VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                  VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
              VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    case Access::DepthRead:
      // Also the colour-output stage: a read-only multisampled depth attachment resolved into
      // a single-sample one is read there (frame::add_resolve_pass).
      return {depth_stages | shaders | VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
              VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT |
                  VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT,
              VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL};
    case Access::HostRead: return {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT, VK_IMAGE_LAYOUT_GENERAL};
    case Access::HostWrite:
      return {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_WRITE_BIT, VK_IMAGE_LAYOUT_GENERAL};
    // The presentation engine reads it after the semaphore Surface::present signals; that
    // signal waits for all earlier work, so the barrier needs no later stage.
    case Access::Present: return {VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR};
  }
  return {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
          VK_IMAGE_LAYOUT_GENERAL};
}

Error vk_error(VkResult result, std::string_view what) {
  std::string_view name = "VkResult";
  switch (result) {
    case VK_ERROR_OUT_OF_HOST_MEMORY: name = "VK_ERROR_OUT_OF_HOST_MEMORY"; break;
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: name = "VK_ERROR_OUT_OF_DEVICE_MEMORY"; break;
    case VK_ERROR_INITIALIZATION_FAILED: name = "VK_ERROR_INITIALIZATION_FAILED"; break;
    case VK_ERROR_DEVICE_LOST: name = "VK_ERROR_DEVICE_LOST"; break;
    case VK_ERROR_LAYER_NOT_PRESENT: name = "VK_ERROR_LAYER_NOT_PRESENT"; break;
    case VK_ERROR_EXTENSION_NOT_PRESENT: name = "VK_ERROR_EXTENSION_NOT_PRESENT"; break;
    case VK_ERROR_FEATURE_NOT_PRESENT: name = "VK_ERROR_FEATURE_NOT_PRESENT"; break;
    case VK_ERROR_INCOMPATIBLE_DRIVER: name = "VK_ERROR_INCOMPATIBLE_DRIVER"; break;
    case VK_ERROR_FORMAT_NOT_SUPPORTED: name = "VK_ERROR_FORMAT_NOT_SUPPORTED"; break;
    case VK_TIMEOUT: name = "VK_TIMEOUT"; break;
    default: break;
  }
  const ErrorKind kind = result == VK_ERROR_LAYER_NOT_PRESENT || result == VK_ERROR_EXTENSION_NOT_PRESENT
                             ? ErrorKind::NotFound
                             : ErrorKind::Device;
  return Error{kind, weft::format("{} failed: {} ({})", what, name, int(result))};
}

}  // namespace weft::gpu::detail
