// Memory, buffers, textures, views, samplers and query sets.
module;
#include <expected>
#include <span>
#include <utility>
#include <cstdint>
#include <string_view>
#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>
#include <cstring>
#include <memory>
#include <string>
#include <vector>
#include <vulkan/vulkan.h>
module weft.gpu;
import weft.core;

namespace weft::gpu::detail {

Allocation::~Allocation() {
  if (owned && memory) {
    vkFreeMemory(device->device, memory, nullptr);
    device->allocated_bytes -= size;
  }
}

Result<std::uint32_t> DeviceShared::find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                                     VkMemoryPropertyFlags preferred) const {
  std::optional<std::uint32_t> fallback;
  for (std::uint32_t i = 0; i < memory_properties.memoryTypeCount; ++i) {
    if (!(type_bits & (1u << i))) continue;
    const auto flags = memory_properties.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (!fallback) fallback = i;
  }
  if (fallback) return *fallback;
  return fail(ErrorKind::Unsupported, "no memory type with properties {:#x} among type bits {:#x}", required, type_bits);
}

Result<std::unique_ptr<Allocation>> DeviceShared::allocate(const VkMemoryRequirements& req,
                                                           VkMemoryPropertyFlags required,
                                                           VkMemoryPropertyFlags preferred, std::string_view label) {
  auto type = find_memory_type(req.memoryTypeBits, required, preferred);
  if (!type) return with_context(weft::format("allocating memory for '{}'", label), type.error());
  VkMemoryAllocateInfo allocate_info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocate_info.allocationSize = req.size;
  allocate_info.memoryTypeIndex = *type;
  auto alloc = std::make_unique<Allocation>();
  if (VkResult r = vkAllocateMemory(device, &allocate_info, nullptr, &alloc->memory); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("allocating {} bytes for '{}'", req.size, label)));
  alloc->size = req.size;
  allocated_bytes += req.size;
  return alloc;
}

}  // namespace weft::gpu::detail

namespace weft::gpu {
using namespace detail;

namespace {
// Checks a placement into a block: in range, aligned, and a compatible memory type.
Result<void> check_placement(const Placement& p, const VkMemoryRequirements& req, std::string_view label) {
  if (p.offset % req.alignment != 0)
    return fail(ErrorKind::InvalidArgument, "'{}': offset {} in memory block '{}' is not aligned to {}", label,
                p.offset, p.block->label(), req.alignment);
  if (p.offset + req.size > p.block->size())
    return fail(ErrorKind::InvalidArgument, "'{}': {} bytes at offset {} overflow memory block '{}' of {} bytes",
                label, req.size, p.offset, p.block->label(), p.block->size());
  return {};
}
}  // namespace

// ---- memory block ---------------------------------------------------------------------

Result<MemoryBlock> Device::create_memory_block(std::string_view label, std::uint64_t size, std::uint32_t type_bits) {
  if (size == 0) return fail(ErrorKind::InvalidArgument, "memory block '{}': size is 0", label);
  if (shared_->declaring())
    return fail(ErrorKind::Unsupported, "memory block '{}': device '{}' has no adapter to allocate from", label,
                shared_->info.name);
  VkMemoryRequirements req{size, 1, type_bits};
  auto alloc = shared_->allocate(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, label);
  if (!alloc) return std::unexpected(alloc.error());
  MemoryBlock block;
  block.device_ = shared_;
  block.memory_ = (*alloc)->memory;
  (*alloc)->memory = VK_NULL_HANDLE;  // the block owns it from here on
  block.size_ = size;
  block.label_ = label;
  block.free_[0] = size;
  shared_->set_name(VK_OBJECT_TYPE_DEVICE_MEMORY, std::uint64_t(block.memory_), label);
  std::uint32_t type_index = 0;
  for (std::uint32_t i = 0; i < 32; ++i)
    if (type_bits & (1u << i)) {
      auto t = shared_->find_memory_type(1u << i, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0);
      if (t) {
        type_index = *t;
        break;
      }
    }
  block.type_index_ = type_index;
  return block;
}

MemoryBlock::MemoryBlock(MemoryBlock&&) noexcept = default;
MemoryBlock& MemoryBlock::operator=(MemoryBlock&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(memory_, o.memory_);
  std::swap(size_, o.size_);
  std::swap(type_index_, o.type_index_);
  std::swap(label_, o.label_);
  std::swap(free_, o.free_);
  std::swap(used_, o.used_);
  return *this;
}
MemoryBlock::~MemoryBlock() {
  if (device_ && memory_) {
    vkFreeMemory(device_->device, memory_, nullptr);
    device_->allocated_bytes -= size_;
  }
}

std::optional<std::uint64_t> MemoryBlock::allocate(std::uint64_t size, std::uint64_t alignment) {
  if (size == 0 || alignment == 0) return std::nullopt;
  for (auto it = free_.begin(); it != free_.end(); ++it) {
    const std::uint64_t start = (it->first + alignment - 1) / alignment * alignment;
    const std::uint64_t end = it->first + it->second;
    if (start + size > end) continue;
    const std::uint64_t free_start = it->first;
    free_.erase(it);
    if (start > free_start) free_[free_start] = start - free_start;
    if (end > start + size) free_[start + size] = end - (start + size);
    used_[start] = size;
    return start;
  }
  return std::nullopt;
}

void MemoryBlock::release(std::uint64_t offset) {
  auto it = used_.find(offset);
  if (it == used_.end()) return;
  std::uint64_t start = offset, size = it->second;
  used_.erase(it);
  // Merge with neighbours so the free list does not fragment.
  auto next = free_.lower_bound(start);
  if (next != free_.end() && next->first == start + size) {
    size += next->second;
    next = free_.erase(next);
  }
  if (next != free_.begin()) {
    auto prev = std::prev(next);
    if (prev->first + prev->second == start) {
      start = prev->first;
      size += prev->second;
      free_.erase(prev);
    }
  }
  free_[start] = size;
}

// ---- buffers --------------------------------------------------------------------------

Result<MemoryRequirements> Device::memory_requirements(const BufferDescriptor& desc) const {
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = desc.size;
  info.usage = to_vk(desc.usage);
  VkDeviceBufferMemoryRequirements q{VK_STRUCTURE_TYPE_DEVICE_BUFFER_MEMORY_REQUIREMENTS, nullptr, &info};
  VkMemoryRequirements2 out{VK_STRUCTURE_TYPE_MEMORY_REQUIREMENTS_2};
  if (desc.size == 0 || info.usage == 0)
    return fail(ErrorKind::InvalidArgument, "buffer '{}': size and usage must be non-zero", desc.label);
  if (shared_->declaring())
    return fail(ErrorKind::Unsupported, "buffer '{}': device '{}' has no adapter to ask for memory requirements",
                desc.label, shared_->info.name);
  vkGetDeviceBufferMemoryRequirements(shared_->device, &q, &out);
  return MemoryRequirements{out.memoryRequirements.size, out.memoryRequirements.alignment,
                            out.memoryRequirements.memoryTypeBits};
}

Result<Buffer> Device::create_buffer(const BufferDescriptor& desc, Placement placement) {
  return DeviceShared::make_buffer(shared_, desc, placement);
}

}  // namespace weft::gpu

namespace weft::gpu::detail {

Result<Buffer> DeviceShared::make_buffer(const std::shared_ptr<DeviceShared>& shared_, const BufferDescriptor& desc,
                                         Placement placement) {
  if (desc.size == 0) return fail(ErrorKind::InvalidArgument, "buffer '{}': size is 0", desc.label);
  if (!any(desc.usage)) return fail(ErrorKind::InvalidArgument, "buffer '{}': no usage flags", desc.label);
  const bool mappable = has(desc.usage, BufferUsage::MapRead) || has(desc.usage, BufferUsage::MapWrite);
  if (mappable && placement.block)
    return fail(ErrorKind::InvalidArgument, "buffer '{}': mappable buffers cannot be placed in a device-local block",
                desc.label);
  if (has(desc.usage, BufferUsage::MapRead) && has(desc.usage, BufferUsage::MapWrite))
    return fail(ErrorKind::InvalidArgument, "buffer '{}': map-read and map-write together are not allowed",
                desc.label);
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = desc.size;
  info.usage = to_vk(desc.usage);
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  Buffer buffer;
  buffer.device_ = shared_;
  buffer.size_ = desc.size;
  buffer.usage_ = desc.usage;
  buffer.label_ = desc.label;
  if (shared_->declaring()) return buffer;
  if (VkResult r = vkCreateBuffer(shared_->device, &info, nullptr, &buffer.buffer_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating buffer '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_BUFFER, std::uint64_t(buffer.buffer_), desc.label);
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(shared_->device, buffer.buffer_, &req);
  if (placement.block) {
    if (auto ok = check_placement(placement, req, desc.label); !ok) return std::unexpected(ok.error());
    vkBindBufferMemory(shared_->device, buffer.buffer_, placement.block->memory_, placement.offset);
    return buffer;
  }
  VkMemoryPropertyFlags required = mappable ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
                                            : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  VkMemoryPropertyFlags preferred = has(desc.usage, BufferUsage::MapRead) ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT : 0;
  auto alloc = shared_->allocate(req, required, preferred, desc.label);
  if (!alloc && !mappable) alloc = shared_->allocate(req, 0, 0, desc.label);
  if (!alloc) return std::unexpected(alloc.error());
  (*alloc)->device = shared_;
  buffer.allocation_ = std::move(*alloc);
  vkBindBufferMemory(shared_->device, buffer.buffer_, buffer.allocation_->memory, 0);
  if (mappable) {
    void* p = nullptr;
    if (VkResult r = vkMapMemory(shared_->device, buffer.allocation_->memory, 0, VK_WHOLE_SIZE, 0, &p); r != VK_SUCCESS)
      return std::unexpected(vk_error(r, weft::format("mapping buffer '{}'", desc.label)));
    buffer.mapped_ = static_cast<std::byte*>(p);
  }
  return buffer;
}

}  // namespace weft::gpu::detail

namespace weft::gpu {

Result<Buffer> Device::create_buffer_with_data(const BufferDescriptor& desc, std::span<const std::byte> data) {
  BufferDescriptor d = desc;
  if (d.size == 0) d.size = data.size();
  if (data.size() > d.size)
    return fail(ErrorKind::InvalidArgument, "buffer '{}': {} bytes of data exceed its size {}", d.label, data.size(),
                d.size);
  if (!has(d.usage, BufferUsage::MapWrite)) d.usage = d.usage | BufferUsage::CopyDst;
  auto buffer = create_buffer(d);
  if (!buffer) return buffer;
  if (auto ok = queue_.write_buffer(*buffer, 0, data); !ok) return std::unexpected(ok.error());
  return buffer;
}

Buffer::Buffer(Buffer&&) noexcept = default;
Buffer& Buffer::operator=(Buffer&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(buffer_, o.buffer_);
  std::swap(allocation_, o.allocation_);
  std::swap(mapped_, o.mapped_);
  std::swap(size_, o.size_);
  std::swap(usage_, o.usage_);
  std::swap(label_, o.label_);
  return *this;
}
Buffer::~Buffer() {
  if (device_ && buffer_) vkDestroyBuffer(device_->device, buffer_, nullptr);
}

Result<std::span<std::byte>> Buffer::mapped() const {
  if (!mapped_)
    return fail(ErrorKind::InvalidArgument, "buffer '{}' is not mappable (usage {} lacks map-read/map-write)", label_,
                to_string(usage_));
  return std::span<std::byte>(mapped_, size_);
}

// ---- textures -------------------------------------------------------------------------

namespace {
Result<VkImageCreateInfo> image_info(const TextureDescriptor& desc, const AdapterInfo& adapter) {
  const FormatInfo& fi = format_info(desc.format);
  if (desc.format == Format::Undefined) return fail(ErrorKind::InvalidArgument, "texture '{}': format is undefined", desc.label);
  if (desc.size.width == 0 || desc.size.height == 0 || desc.size.depth_or_layers == 0)
    return fail(ErrorKind::InvalidArgument, "texture '{}': size {}x{}x{} has a zero dimension", desc.label,
                desc.size.width, desc.size.height, desc.size.depth_or_layers);
  const std::uint32_t max_dim = adapter.limits.max_texture_dimension_2d;
  if (desc.size.width > max_dim || desc.size.height > max_dim)
    return fail(ErrorKind::InvalidArgument, "texture '{}': size {}x{} exceeds the adapter's limit {}", desc.label,
                desc.size.width, desc.size.height, max_dim);
  if (!any(desc.usage)) return fail(ErrorKind::InvalidArgument, "texture '{}': no usage flags", desc.label);
  if (std::string bad = forbidden_usages(desc.format, desc.usage); !bad.empty())
    return fail(ErrorKind::InvalidArgument, "texture '{}': format {} cannot take usage {}", desc.label, fi.name, bad);
  const std::uint32_t max_mips =
      1 + std::uint32_t(std::floor(std::log2(double(std::max(desc.size.width, desc.size.height)))));
  if (desc.mip_level_count == 0 || desc.mip_level_count > max_mips)
    return fail(ErrorKind::InvalidArgument, "texture '{}': {} mip levels, a {}x{} texture has 1 to {}", desc.label,
                desc.mip_level_count, desc.size.width, desc.size.height, max_mips);
  if (desc.dimension == TextureDimension::Cube && (desc.size.depth_or_layers != 6 || desc.size.width != desc.size.height))
    return fail(ErrorKind::InvalidArgument, "texture '{}': a cube texture needs 6 square layers", desc.label);
  if (desc.sample_count != 1) {
    const Limits& l = adapter.limits;
    std::uint32_t counts = fi.depth ? l.depth_sample_counts : l.color_sample_counts;
    if (has(desc.usage, TextureUsage::Sampled)) counts &= fi.depth ? l.sampled_depth_sample_counts : l.sampled_color_sample_counts;
    if (std::popcount(desc.sample_count) != 1 || !(counts & desc.sample_count))
      return fail(ErrorKind::InvalidArgument, "texture '{}': {} samples; adapter '{}' has {} for a {} {}{} texture",
                  desc.label, desc.sample_count, adapter.name, sample_counts_text(counts), fi.depth ? "depth" : "colour",
                  fi.name, has(desc.usage, TextureUsage::Sampled) ? " sampled" : "");
    if (desc.mip_level_count != 1 || (desc.dimension != TextureDimension::D2 && desc.dimension != TextureDimension::D2Array))
      return fail(ErrorKind::InvalidArgument,
                  "texture '{}': {} samples need a 2D texture with one mip level (has {} mips, {})", desc.label,
                  desc.sample_count, desc.mip_level_count,
                  desc.dimension == TextureDimension::Cube ? "cube" : desc.dimension == TextureDimension::D3 ? "3D" : "2D");
    if (has(desc.usage, TextureUsage::Storage))
      return fail(ErrorKind::InvalidArgument, "texture '{}': a multisampled texture ({} samples) cannot be a storage image",
                  desc.label, desc.sample_count);
  }
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = desc.dimension == TextureDimension::D3 ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D;
  info.format = detail::to_vk(desc.format);
  info.extent = {desc.size.width, desc.size.height, desc.dimension == TextureDimension::D3 ? desc.size.depth_or_layers : 1};
  info.mipLevels = desc.mip_level_count;
  info.arrayLayers = desc.dimension == TextureDimension::D3 ? 1 : desc.size.depth_or_layers;
  info.samples = VkSampleCountFlagBits(desc.sample_count);
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = detail::to_vk(desc.usage);
  // Sampled depth lives in the read-only depth layout, which Vulkan allows only on images
  // that could be depth attachments; adding the bit costs nothing.
  if (fi.depth) info.usage |= VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  if (desc.dimension == TextureDimension::Cube) info.flags |= VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT;
  return info;
}

VkImageViewType view_type(TextureDimension d) {
  switch (d) {
    case TextureDimension::D2: return VK_IMAGE_VIEW_TYPE_2D;
    case TextureDimension::D2Array: return VK_IMAGE_VIEW_TYPE_2D_ARRAY;
    case TextureDimension::Cube: return VK_IMAGE_VIEW_TYPE_CUBE;
    case TextureDimension::D3: return VK_IMAGE_VIEW_TYPE_3D;
  }
  return VK_IMAGE_VIEW_TYPE_2D;
}
}  // namespace

Result<MemoryRequirements> Device::memory_requirements(const TextureDescriptor& desc) const {
  auto info = image_info(desc, shared_->info);
  if (!info) return std::unexpected(info.error());
  if (shared_->declaring())
    return fail(ErrorKind::Unsupported, "texture '{}': device '{}' has no adapter to ask for memory requirements",
                desc.label, shared_->info.name);
  VkDeviceImageMemoryRequirements q{VK_STRUCTURE_TYPE_DEVICE_IMAGE_MEMORY_REQUIREMENTS, nullptr, &*info};
  VkMemoryRequirements2 out{VK_STRUCTURE_TYPE_MEMORY_REQUIREMENTS_2};
  vkGetDeviceImageMemoryRequirements(shared_->device, &q, &out);
  return MemoryRequirements{out.memoryRequirements.size, out.memoryRequirements.alignment,
                            out.memoryRequirements.memoryTypeBits};
}

Result<Texture> Device::create_texture(const TextureDescriptor& desc, Placement placement) {
  auto info = image_info(desc, shared_->info);
  if (!info) return std::unexpected(info.error());
  Texture texture;
  texture.device_ = shared_;
  texture.desc_ = desc;
  if (shared_->declaring()) {
    texture.default_view_.reset(new TextureView());
    texture.default_view_->mip_count_ = desc.mip_level_count;
    texture.fix_view_back_pointer();
    return texture;
  }
  if (VkResult r = vkCreateImage(shared_->device, &*info, nullptr, &texture.image_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating texture '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_IMAGE, std::uint64_t(texture.image_), desc.label);
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(shared_->device, texture.image_, &req);
  if (placement.block) {
    if (auto ok = check_placement(placement, req, desc.label); !ok) return std::unexpected(ok.error());
    vkBindImageMemory(shared_->device, texture.image_, placement.block->memory_, placement.offset);
  } else {
    auto alloc = shared_->allocate(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, desc.label);
    if (!alloc) alloc = shared_->allocate(req, 0, 0, desc.label);
    if (!alloc) return std::unexpected(alloc.error());
    (*alloc)->device = shared_;
    texture.allocation_ = std::move(*alloc);
    vkBindImageMemory(shared_->device, texture.image_, texture.allocation_->memory, 0);
  }
  const TextureUsage viewable = TextureUsage::Sampled | TextureUsage::Storage | TextureUsage::ColorAttachment |
                                TextureUsage::DepthAttachment;
  if (any(desc.usage & viewable)) {
    auto view = texture.create_view({0, desc.mip_level_count});
    if (!view) return std::unexpected(view.error());
    texture.default_view_ = std::make_unique<TextureView>(std::move(*view));
  } else {
    texture.default_view_.reset(new TextureView());
  }
  texture.fix_view_back_pointer();
  return texture;
}

Result<TextureView> Texture::create_view(const TextureViewDescriptor& d) const {
  if (d.mip_count == 0 || d.base_mip + std::uint64_t(d.mip_count) > desc_.mip_level_count)
    return fail(ErrorKind::InvalidArgument, "texture '{}': view of mips [{}, {}) but it has {}", desc_.label,
                d.base_mip, std::uint64_t(d.base_mip) + d.mip_count, desc_.mip_level_count);
  const std::uint32_t layers = layer_count();
  const TextureRange range{d.base_mip, d.mip_count, d.base_layer, d.layer_count};
  if (!range.fits(desc_.mip_level_count, layers))
    return fail(ErrorKind::InvalidArgument, "texture '{}': view of {} but it has {} layer{}", desc_.label,
                describe(range), layers, layers == 1 ? "" : "s");
  const std::uint32_t layer_count = range.layers_of(layers);
  VkImageViewCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  info.image = image_;
  // All of its layers: the texture's own type; one layer of an array or cube: 2D (a face to
  // render into or sample alone); several: an array of them.
  info.viewType = layer_count == layers || desc_.dimension == TextureDimension::D3 ? view_type(desc_.dimension)
                  : layer_count == 1                                                ? VK_IMAGE_VIEW_TYPE_2D
                                                                                    : VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  info.format = detail::to_vk(desc_.format);
  // Views used for sampling see depth only; stencil would need its own view.
  info.subresourceRange = {aspect_of(desc_.format) & ~VkImageAspectFlags(VK_IMAGE_ASPECT_STENCIL_BIT), d.base_mip,
                           d.mip_count, d.base_layer, layer_count};
  TextureView view;
  view.device_ = device_;
  view.texture_ = this;
  view.base_mip_ = d.base_mip;
  view.mip_count_ = d.mip_count;
  view.base_layer_ = d.base_layer;
  view.layer_count_ = layer_count;
  if (!image_) return view;  // a declaring device's texture: a view of nothing, like its texture
  if (VkResult r = vkCreateImageView(device_->device, &info, nullptr, &view.view_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating a view of texture '{}'", desc_.label)));
  return view;
}

void Texture::fix_view_back_pointer() {
  if (default_view_) default_view_->texture_ = this;
}

Texture::Texture(Texture&& o) noexcept
    : device_(std::move(o.device_)),
      image_(std::exchange(o.image_, VK_NULL_HANDLE)),
      allocation_(std::move(o.allocation_)),
      default_view_(std::move(o.default_view_)),
      desc_(std::move(o.desc_)),
      state_(o.state_),
      owns_image_(o.owns_image_) {
  fix_view_back_pointer();
}
Texture& Texture::operator=(Texture&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(image_, o.image_);
  std::swap(allocation_, o.allocation_);
  std::swap(default_view_, o.default_view_);
  std::swap(desc_, o.desc_);
  std::swap(state_, o.state_);
  std::swap(owns_image_, o.owns_image_);
  fix_view_back_pointer();
  o.fix_view_back_pointer();
  return *this;
}
Texture::~Texture() {
  default_view_.reset();
  if (device_ && image_ && owns_image_) vkDestroyImage(device_->device, image_, nullptr);
}

TextureView::TextureView(TextureView&&) noexcept = default;
TextureView& TextureView::operator=(TextureView&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(view_, o.view_);
  std::swap(texture_, o.texture_);
  std::swap(base_mip_, o.base_mip_);
  std::swap(mip_count_, o.mip_count_);
  return *this;
}
TextureView::~TextureView() {
  if (device_ && view_) vkDestroyImageView(device_->device, view_, nullptr);
}

// ---- samplers -------------------------------------------------------------------------

Result<Sampler> Device::create_sampler(const SamplerDescriptor& desc) {
  auto filter = [](FilterMode m) { return m == FilterMode::Linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST; };
  auto address = [](AddressMode m) {
    switch (m) {
      case AddressMode::Repeat: return VK_SAMPLER_ADDRESS_MODE_REPEAT;
      case AddressMode::MirrorRepeat: return VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT;
      default: return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    }
  };
  if (!(desc.max_lod >= 0.0f))
    return fail(ErrorKind::InvalidArgument, "sampler '{}': max_lod {} must be >= 0", desc.label, desc.max_lod);
  if (!(desc.max_anisotropy >= 1.0f) || !std::isfinite(desc.max_anisotropy))
    return fail(ErrorKind::InvalidArgument, "sampler '{}': max_anisotropy {} must be a number >= 1 (1 is off)",
                desc.label, desc.max_anisotropy);
  const float anisotropy = std::min(desc.max_anisotropy, shared_->info.limits.max_sampler_anisotropy);
  if (anisotropy > 1.0f && (desc.min_filter != FilterMode::Linear || desc.mag_filter != FilterMode::Linear ||
                            desc.mipmap_filter != FilterMode::Linear))
    return fail(ErrorKind::InvalidArgument, "sampler '{}': anisotropic filtering ({}) needs linear filters", desc.label,
                desc.max_anisotropy);
  VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  info.magFilter = filter(desc.mag_filter);
  info.minFilter = filter(desc.min_filter);
  info.mipmapMode = desc.mipmap_filter == FilterMode::Linear ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST;
  info.addressModeU = address(desc.address_mode);
  info.addressModeV = info.addressModeW = address(desc.address_mode_v.value_or(desc.address_mode));
  info.compareEnable = desc.compare.has_value();
  info.compareOp = desc.compare ? to_vk(*desc.compare) : VK_COMPARE_OP_ALWAYS;
  info.maxLod = desc.max_lod;
  info.anisotropyEnable = anisotropy > 1.0f;
  info.maxAnisotropy = anisotropy;
  info.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
  Sampler sampler;
  sampler.device_ = shared_;
  sampler.label_ = desc.label;
  sampler.comparison_ = desc.compare.has_value();
  if (shared_->declaring()) return sampler;
  if (VkResult r = vkCreateSampler(shared_->device, &info, nullptr, &sampler.sampler_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating sampler '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_SAMPLER, std::uint64_t(sampler.sampler_), desc.label);
  return sampler;
}

Sampler::Sampler(Sampler&&) noexcept = default;
Sampler& Sampler::operator=(Sampler&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(sampler_, o.sampler_);
  std::swap(label_, o.label_);
  std::swap(comparison_, o.comparison_);
  return *this;
}
Sampler::~Sampler() {
  if (device_ && sampler_) vkDestroySampler(device_->device, sampler_, nullptr);
}

// ---- query sets -----------------------------------------------------------------------

Result<QuerySet> Device::create_query_set(std::string_view label, std::uint32_t count) {
  if (count == 0) return fail(ErrorKind::InvalidArgument, "query set '{}': count is 0", label);
  if (!shared_->info.limits.timestamps)
    return fail(ErrorKind::Unsupported, "query set '{}': adapter '{}' has no timestamp queries", label,
                shared_->info.name);
  VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = count;
  QuerySet set;
  set.device_ = shared_;
  set.count_ = count;
  set.label_ = label;
  if (VkResult r = vkCreateQueryPool(shared_->device, &info, nullptr, &set.pool_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating query set '{}'", label)));
  shared_->set_name(VK_OBJECT_TYPE_QUERY_POOL, std::uint64_t(set.pool_), label);
  return set;
}

QuerySet::QuerySet(QuerySet&&) noexcept = default;
QuerySet& QuerySet::operator=(QuerySet&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pool_, o.pool_);
  std::swap(count_, o.count_);
  std::swap(label_, o.label_);
  return *this;
}
QuerySet::~QuerySet() {
  if (device_ && pool_) vkDestroyQueryPool(device_->device, pool_, nullptr);
}

Result<std::vector<double>> QuerySet::read_timestamps_ns(std::uint32_t first, std::uint32_t n) const {
  if (first + n > count_)
    return fail(ErrorKind::InvalidArgument, "query set '{}': queries [{}, {}) out of range (count {})", label_, first,
                first + n, count_);
  std::vector<std::uint64_t> raw(n);
  VkResult r = vkGetQueryPoolResults(device_->device, pool_, first, n, n * sizeof(std::uint64_t), raw.data(),
                                     sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
  if (r != VK_SUCCESS) return std::unexpected(vk_error(r, weft::format("reading query set '{}'", label_)));
  std::vector<double> out(n);
  for (std::uint32_t i = 0; i < n; ++i) out[i] = double(raw[i]) * device_->info.limits.timestamp_period_ns;
  return out;
}

}  // namespace weft::gpu
