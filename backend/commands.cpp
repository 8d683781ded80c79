// Command recording (encoders, passes, copies, barriers, timestamps) and the queue.
module;
#include <expected>
#include <optional>
#include <span>
#include <utility>
#include <cstdint>
#include <string_view>
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>
#include <vulkan/vulkan.h>
module weft.gpu;
import weft.core;

namespace weft::gpu {
using namespace detail;

namespace {
PFN_vkCmdBeginDebugUtilsLabelEXT begin_label_fn(const DeviceShared& d) {
  if (!d.instance->debug_utils) return nullptr;
  return reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(d.instance->instance, "vkCmdBeginDebugUtilsLabelEXT"));
}
PFN_vkCmdEndDebugUtilsLabelEXT end_label_fn(const DeviceShared& d) {
  if (!d.instance->debug_utils) return nullptr;
  return reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(d.instance->instance, "vkCmdEndDebugUtilsLabelEXT"));
}

VkImageSubresourceLayers mip_layers(const Texture& t, std::uint32_t mip) {
  return {aspect_of(t.format()) & ~VkImageAspectFlags(VK_IMAGE_ASPECT_STENCIL_BIT), mip, 0,
          t.descriptor().dimension == TextureDimension::D3 ? 1 : t.size().depth_or_layers};
}

VkExtent3D mip_extent(const Texture& t, std::uint32_t mip) {
  const auto s = t.size();
  const std::uint32_t depth = t.descriptor().dimension == TextureDimension::D3 ? std::max(1u, s.depth_or_layers >> mip) : 1;
  return {std::max(1u, s.width >> mip), std::max(1u, s.height >> mip), depth};
}

std::uint64_t mip_bytes(const Texture& t, std::uint32_t mip) {
  const VkExtent3D e = mip_extent(t, mip);
  const std::uint64_t layers = t.descriptor().dimension == TextureDimension::D3 ? 1 : t.size().depth_or_layers;
  return std::uint64_t(e.width) * e.height * e.depth * layers * format_info(t.format()).bytes_per_texel;
}
}  // namespace

// ---- command encoder ------------------------------------------------------------------

Result<CommandEncoder> Device::create_command_encoder(std::string_view label) {
  return DeviceShared::make_encoder(shared_, label);
}

CommandEncoder::CommandEncoder(CommandEncoder&&) noexcept = default;
CommandEncoder& CommandEncoder::operator=(CommandEncoder&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pool_, o.pool_);
  std::swap(cmd_, o.cmd_);
  std::swap(label_, o.label_);
  std::swap(error_, o.error_);
  std::swap(in_pass_, o.in_pass_);
  return *this;
}
CommandEncoder::~CommandEncoder() {
  if (device_ && cmd_) vkFreeCommandBuffers(device_->device, pool_, 1, &cmd_);
}

void CommandEncoder::report_error(Error error) {
  if (!error_) error_ = std::move(error);
}

bool CommandEncoder::check_outside_pass(std::string_view what) {
  if (in_pass_) {
    report_error({ErrorKind::InvalidArgument,
                  weft::format("command encoder '{}': {} inside a render or compute pass", label_, what)});
    return false;
  }
  return !error_.has_value();
}

Result<CommandBuffer> CommandEncoder::finish() {
  if (in_pass_) report_error({ErrorKind::InvalidArgument, weft::format("command encoder '{}': finish() with a pass still open", label_)});
  if (error_) return std::unexpected(*error_);
  if (VkResult r = vkEndCommandBuffer(cmd_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("finishing command encoder '{}'", label_)));
  CommandBuffer out;
  out.device_ = std::move(device_);
  out.pool_ = std::exchange(pool_, VK_NULL_HANDLE);
  out.cmd_ = std::exchange(cmd_, VK_NULL_HANDLE);
  out.label_ = label_;
  return out;
}

CommandBuffer::CommandBuffer(CommandBuffer&&) noexcept = default;
CommandBuffer& CommandBuffer::operator=(CommandBuffer&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pool_, o.pool_);
  std::swap(cmd_, o.cmd_);
  std::swap(label_, o.label_);
  return *this;
}
CommandBuffer::~CommandBuffer() {
  if (device_ && cmd_) vkFreeCommandBuffers(device_->device, pool_, 1, &cmd_);
}

void CommandEncoder::push_debug_group(std::string_view label) {
  if (auto fn = begin_label_fn(*device_)) {
    std::string name(label);
    VkDebugUtilsLabelEXT l{VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
    l.pLabelName = name.c_str();
    fn(cmd_, &l);
  }
}

void CommandEncoder::pop_debug_group() {
  if (auto fn = end_label_fn(*device_)) fn(cmd_);
}

void CommandEncoder::barrier(std::span<const TextureBarrier> textures, std::span<const BufferBarrier> buffers) {
  if (!check_outside_pass("barrier")) return;
  // Most barriers move a few textures: those go on the stack, so recording a frame's barriers
  // allocates nothing (a render graph issues one call per pass).
  constexpr std::size_t on_stack = 16;
  VkImageMemoryBarrier2 small[on_stack];
  std::vector<VkImageMemoryBarrier2> large;
  if (textures.size() > on_stack) large.resize(textures.size());
  VkImageMemoryBarrier2* const images = textures.size() > on_stack ? large.data() : small;
  std::uint32_t image_count = 0;
  for (const auto& b : textures) {
    const bool depth = format_info(b.texture->format()).depth;
    const StageAccess src = stage_access(b.before, depth), dst = stage_access(b.after, depth);
    VkImageMemoryBarrier2 m{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    m.srcStageMask = src.stages;
    m.srcAccessMask = is_write(b.before) ? src.access : VK_ACCESS_2_NONE;  // only writes need making available
    m.dstStageMask = dst.stages;
    m.dstAccessMask = dst.access;
    m.oldLayout = src.layout;
    m.newLayout = dst.layout;
    m.srcQueueFamilyIndex = m.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    m.image = b.texture->image_;
    const TextureRange& r = b.range;
    if (r != TextureRange{} && !r.fits(b.texture->descriptor().mip_level_count, b.texture->layer_count())) {
      report_error({ErrorKind::InvalidArgument,
                    weft::format("barrier on texture '{}': {} is not part of it ({} mips, {} layers)",
                                 b.texture->label(), describe(r), b.texture->descriptor().mip_level_count,
                                 b.texture->layer_count())});
      continue;
    }
    m.subresourceRange = {aspect_of(b.texture->format()), r.base_mip,
                          r.mip_count == TextureRange::remaining ? VK_REMAINING_MIP_LEVELS : r.mip_count, r.base_layer,
                          r.layer_count == TextureRange::remaining ? VK_REMAINING_ARRAY_LAYERS : r.layer_count};
    images[image_count++] = m;
    b.texture->state_ = b.after;
  }
  // Buffers need no layout, so one global memory barrier covers them all.
  VkMemoryBarrier2 global{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  for (const auto& b : buffers) {
    const StageAccess src = stage_access(b.before, false), dst = stage_access(b.after, false);
    global.srcStageMask |= src.stages;
    if (is_write(b.before)) global.srcAccessMask |= src.access;
    global.dstStageMask |= dst.stages;
    global.dstAccessMask |= dst.access;
  }
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = buffers.empty() ? 0 : 1;
  dep.pMemoryBarriers = &global;
  dep.imageMemoryBarrierCount = image_count;
  dep.pImageMemoryBarriers = images;
  if (dep.memoryBarrierCount || dep.imageMemoryBarrierCount) vkCmdPipelineBarrier2(cmd_, &dep);
}

void CommandEncoder::transition(const Texture& texture, Access after) {
  const TextureBarrier b{&texture, texture.state(), after};
  barrier(std::span(&b, 1));
}

void CommandEncoder::copy_buffer_to_buffer(const Buffer& src, std::uint64_t src_offset, const Buffer& dst,
                                           std::uint64_t dst_offset, std::uint64_t size) {
  if (!check_outside_pass("copy_buffer_to_buffer")) return;
  if (!has(src.usage(), BufferUsage::CopySrc) && !has(src.usage(), BufferUsage::MapWrite))
    return report_error({ErrorKind::InvalidArgument, weft::format("copy source buffer '{}' lacks copy-src usage (has {})", src.label(), to_string(src.usage()))});
  if (!has(dst.usage(), BufferUsage::CopyDst) && !has(dst.usage(), BufferUsage::MapRead))
    return report_error({ErrorKind::InvalidArgument, weft::format("copy destination buffer '{}' lacks copy-dst usage (has {})", dst.label(), to_string(dst.usage()))});
  if (size == 0 || src_offset + size > src.size() || dst_offset + size > dst.size())
    return report_error({ErrorKind::InvalidArgument,
                         weft::format("copy of {} bytes from '{}'+{} ({} bytes) to '{}'+{} ({} bytes) is out of range",
                                     size, src.label(), src_offset, src.size(), dst.label(), dst_offset, dst.size())});
  VkBufferCopy region{src_offset, dst_offset, size};
  vkCmdCopyBuffer(cmd_, src.buffer_, dst.buffer_, 1, &region);
}

namespace {
// Validates a buffer<->texture copy of one mip and returns its region, or the error.
Result<VkBufferImageCopy> texture_copy_region(const Texture& texture, TextureUsage needed, const Buffer& buffer,
                                              std::uint64_t offset, std::uint32_t mip) {
  const char* role = needed == TextureUsage::CopyDst ? "destination" : "source";
  if (!has(texture.usage(), needed))
    return fail(ErrorKind::InvalidArgument, "copy {} texture '{}' lacks {} usage (has {})", role, texture.label(),
                to_string(needed), to_string(texture.usage()));
  if (mip >= texture.descriptor().mip_level_count)
    return fail(ErrorKind::InvalidArgument, "texture '{}' has no mip {}", texture.label(), mip);
  if (texture.sample_count() != 1)
    return fail(ErrorKind::InvalidArgument,
                "copy {} texture '{}' has {} samples: resolve it into a single-sample texture first", role,
                texture.label(), texture.sample_count());
  if (offset + mip_bytes(texture, mip) > buffer.size())
    return fail(ErrorKind::InvalidArgument,
                "buffer '{}' ({} bytes from offset {}) is too small for mip {} of texture '{}' ({} bytes)",
                buffer.label(), buffer.size(), offset, mip, texture.label(), mip_bytes(texture, mip));
  VkBufferImageCopy region{};
  region.bufferOffset = offset;
  region.imageSubresource = mip_layers(texture, mip);
  region.imageExtent = mip_extent(texture, mip);
  return region;
}
}  // namespace

void CommandEncoder::copy_buffer_to_texture(const Buffer& src, std::uint64_t src_offset, const Texture& dst,
                                            std::uint32_t mip) {
  if (!check_outside_pass("copy_buffer_to_texture")) return;
  auto region = texture_copy_region(dst, TextureUsage::CopyDst, src, src_offset, mip);
  if (!region) return report_error(region.error());
  vkCmdCopyBufferToImage(cmd_, src.buffer_, dst.image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &*region);
}

void CommandEncoder::copy_texture_to_buffer(const Texture& src, const Buffer& dst, std::uint64_t dst_offset,
                                            std::uint32_t mip) {
  if (!check_outside_pass("copy_texture_to_buffer")) return;
  auto region = texture_copy_region(src, TextureUsage::CopySrc, dst, dst_offset, mip);
  if (!region) return report_error(region.error());
  vkCmdCopyImageToBuffer(cmd_, src.image_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.buffer_, 1, &*region);
}

void CommandEncoder::fill_buffer(const Buffer& buffer, std::uint32_t value, std::uint64_t offset, std::uint64_t size) {
  if (!check_outside_pass("fill_buffer")) return;
  if (!has(buffer.usage(), BufferUsage::CopyDst))
    return report_error({ErrorKind::InvalidArgument, weft::format("filled buffer '{}' lacks copy-dst usage (has {})", buffer.label(), to_string(buffer.usage()))});
  const std::uint64_t n = size ? size : buffer.size() - offset;
  if (offset % 4 || n % 4 || offset + n > buffer.size())
    return report_error({ErrorKind::InvalidArgument, weft::format("fill of buffer '{}': range [{}, {}) must be 4-byte aligned and within {} bytes",
                                                                 buffer.label(), offset, offset + n, buffer.size())});
  vkCmdFillBuffer(cmd_, buffer.buffer_, offset, n, value);
}

void CommandEncoder::blit_texture(const Texture& src, const Texture& dst, FilterMode filter) {
  blit_texture(src, 0, dst, 0, filter);
}

void CommandEncoder::blit_texture(const Texture& src, std::uint32_t src_mip, const Texture& dst, std::uint32_t dst_mip,
                                  FilterMode filter) {
  if (!check_outside_pass("blit_texture")) return;
  auto bad = [&](std::string message) { report_error({ErrorKind::InvalidArgument, std::move(message)}); };
  if (!has(src.usage(), TextureUsage::CopySrc))
    return bad(weft::format("blit source '{}' lacks copy-src usage (has {})", src.label(), to_string(src.usage())));
  if (!has(dst.usage(), TextureUsage::CopyDst))
    return bad(weft::format("blit target '{}' lacks copy-dst usage (has {})", dst.label(), to_string(dst.usage())));
  if (format_info(src.format()).depth || format_info(dst.format()).depth)
    return bad(weft::format("blit from '{}' to '{}': depth textures cannot be blitted", src.label(), dst.label()));
  if (src.sample_count() != 1 || dst.sample_count() != 1)
    return bad(weft::format("blit from '{}' ({} samples) to '{}' ({} samples): multisampled textures are resolved, "
                            "not blitted (ColorAttachment::resolve_target)",
                            src.label(), src.sample_count(), dst.label(), dst.sample_count()));
  if (src_mip >= src.descriptor().mip_level_count || dst_mip >= dst.descriptor().mip_level_count)
    return bad(weft::format("blit from mip {} of '{}' ({} mips) to mip {} of '{}' ({} mips): no such mip", src_mip,
                            src.label(), src.descriptor().mip_level_count, dst_mip, dst.label(),
                            dst.descriptor().mip_level_count));
  if (&src == &dst && src_mip == dst_mip)
    return bad(weft::format("blit of mip {} of '{}' onto itself: a blit reads one mip and writes another", src_mip,
                            src.label()));
  if (src.layer_count() != dst.layer_count())
    return bad(weft::format("blit from '{}' ({} layers) to '{}' ({} layers): every layer is blitted, so the counts "
                            "must match",
                            src.label(), src.layer_count(), dst.label(), dst.layer_count()));
  const VkExtent3D from = mip_extent(src, src_mip), to = mip_extent(dst, dst_mip);
  VkImageBlit2 region{VK_STRUCTURE_TYPE_IMAGE_BLIT_2};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, src_mip, 0, src.layer_count()};
  region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, dst_mip, 0, dst.layer_count()};
  region.srcOffsets[1] = {std::int32_t(from.width), std::int32_t(from.height), 1};
  region.dstOffsets[1] = {std::int32_t(to.width), std::int32_t(to.height), 1};
  VkBlitImageInfo2 info{VK_STRUCTURE_TYPE_BLIT_IMAGE_INFO_2};
  info.srcImage = src.image_;
  info.srcImageLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  info.dstImage = dst.image_;
  info.dstImageLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  info.regionCount = 1;
  info.pRegions = &region;
  info.filter = filter == FilterMode::Linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  vkCmdBlitImage2(cmd_, &info);
}

void CommandEncoder::resolve_texture(const Texture& src, const Texture& dst) {
  if (!check_outside_pass("resolve_texture")) return;
  auto bad = [&](std::string message) { report_error({ErrorKind::InvalidArgument, std::move(message)}); };
  if (!has(src.usage(), TextureUsage::CopySrc))
    return bad(weft::format("resolve source '{}' lacks copy-src usage (has {})", src.label(), to_string(src.usage())));
  if (!has(dst.usage(), TextureUsage::CopyDst))
    return bad(weft::format("resolve target '{}' lacks copy-dst usage (has {})", dst.label(), to_string(dst.usage())));
  if (format_info(src.format()).depth)
    return bad(weft::format("resolve of '{}': a depth texture resolves in a render pass (DepthAttachment::resolve_target)",
                            src.label()));
  if (src.sample_count() == 1 || dst.sample_count() != 1)
    return bad(weft::format("resolve from '{}' ({} samples) to '{}' ({} samples): the source must be multisampled and the "
                            "target single-sample",
                            src.label(), src.sample_count(), dst.label(), dst.sample_count()));
  if (src.format() != dst.format() || src.size().width != dst.size().width || src.size().height != dst.size().height)
    return bad(weft::format("resolve from '{}' ({}, {}x{}) to '{}' ({}, {}x{}): format and size must match", src.label(),
                            to_string(src.format()), src.size().width, src.size().height, dst.label(),
                            to_string(dst.format()), dst.size().width, dst.size().height));
  VkImageResolve2 region{VK_STRUCTURE_TYPE_IMAGE_RESOLVE_2};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.extent = {src.size().width, src.size().height, 1};
  VkResolveImageInfo2 info{VK_STRUCTURE_TYPE_RESOLVE_IMAGE_INFO_2};
  info.srcImage = src.image_;
  info.srcImageLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  info.dstImage = dst.image_;
  info.dstImageLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  info.regionCount = 1;
  info.pRegions = &region;
  vkCmdResolveImage2(cmd_, &info);
}

void CommandEncoder::reset_query_set(const QuerySet& set) {
  if (!check_outside_pass("reset_query_set")) return;
  vkCmdResetQueryPool(cmd_, set.pool_, 0, set.count());
}

void CommandEncoder::write_timestamp(const QuerySet& set, std::uint32_t index) {
  if (index >= set.count())
    return report_error({ErrorKind::InvalidArgument, weft::format("timestamp {} is out of range of query set '{}' ({} queries)", index, set.label(), set.count())});
  vkCmdWriteTimestamp2(cmd_, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, set.pool_, index);
}

// ---- render passes --------------------------------------------------------------------

RenderPassEncoder CommandEncoder::begin_render_pass(const RenderPassDescriptor& desc) {
  RenderPassEncoder pass(this);
  pass.label_ = desc.label;
  if (!check_outside_pass(weft::format("beginning render pass '{}'", desc.label))) {
    pass.ended_ = true;
    return pass;
  }
  auto bad = [&](std::string message) {
    report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': {}", desc.label, message)});
    pass.ended_ = true;
    return std::move(pass);
  };
  if (desc.color_attachments.empty() && !desc.depth_attachment) return bad("no attachments");
  auto load_op = [](LoadOp op) {
    return op == LoadOp::Clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : op == LoadOp::Load ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  };
  auto store_op = [](StoreOp op) { return op == StoreOp::Store ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE; };
  std::optional<Extent3D> extent;
  auto check_size = [&](const TextureView& v) -> bool {
    const VkExtent3D e = mip_extent(v.texture(), v.base_mip());
    Extent3D s{e.width, e.height, 1};
    if (!extent) extent = s;
    return *extent == s;
  };
  // Every attachment of a pass has one sample count (the first one's).
  std::optional<std::pair<std::uint32_t, std::string>> samples;
  auto check_samples = [&](const Texture& t, std::string what) -> bool {
    if (!samples) samples.emplace(t.sample_count(), weft::format("{} '{}'", what, t.label()));
    if (samples->first == t.sample_count()) return true;
    bad(weft::format("{} '{}' has {} samples, {} has {}: a pass's attachments share one sample count", what, t.label(),
                     t.sample_count(), samples->second, samples->first));
    return false;
  };
  auto resolve_problem = [](const Texture& t, const TextureView& v, const Texture& r, const TextureView& rv) -> std::string {
    if (t.sample_count() == 1)
      return weft::format("texture '{}' has one sample: there is nothing to resolve into '{}'", t.label(), r.label());
    if (r.sample_count() != 1)
      return weft::format("resolve target '{}' has {} samples (needs 1)", r.label(), r.sample_count());
    if (r.format() != t.format())
      return weft::format("resolve target '{}' is {}, the attachment '{}' is {}", r.label(), to_string(r.format()),
                          t.label(), to_string(t.format()));
    const VkExtent3D a = mip_extent(t, v.base_mip()), b = mip_extent(r, rv.base_mip());
    if (a.width != b.width || a.height != b.height)
      return weft::format("resolve target '{}' is {}x{}, the attachment '{}' is {}x{}", r.label(), b.width, b.height,
                          t.label(), a.width, a.height);
    if (!has(r.usage(), t.format() == r.format() && format_info(r.format()).depth ? TextureUsage::DepthAttachment
                                                                                   : TextureUsage::ColorAttachment))
      return weft::format("resolve target '{}' lacks {} usage (has {})", r.label(),
                          format_info(r.format()).depth ? "depth-attachment" : "color-attachment", to_string(r.usage()));
    return {};
  };
  std::vector<VkRenderingAttachmentInfo> colors;
  for (std::size_t i = 0; i < desc.color_attachments.size(); ++i) {
    const auto& a = desc.color_attachments[i];
    if (!a.view) return bad(weft::format("color attachment {} has no view", i));
    const Texture& t = a.view->texture();
    if (!has(t.usage(), TextureUsage::ColorAttachment))
      return bad(weft::format("color attachment {} texture '{}' lacks color-attachment usage (has {})", i, t.label(), to_string(t.usage())));
    if (!check_size(*a.view))
      return bad(weft::format("color attachment {} texture '{}' is {}x{}, the first attachment is {}x{}", i, t.label(),
                             t.size().width >> a.view->base_mip(), t.size().height >> a.view->base_mip(), extent->width, extent->height));
    if (!check_samples(t, weft::format("color attachment {}", i))) return pass;
    VkRenderingAttachmentInfo info{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    info.imageView = a.view->view_;
    info.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    info.loadOp = load_op(a.load);
    info.storeOp = store_op(a.store);
    info.clearValue.color = {{a.clear_color.x, a.clear_color.y, a.clear_color.z, a.clear_color.w}};
    if (a.resolve_target) {
      const Texture& r = a.resolve_target->texture();
      if (auto problem = resolve_problem(t, *a.view, r, *a.resolve_target); !problem.empty())
        return bad(weft::format("color attachment {}: {}", i, problem));
      // Averaging is what a colour resolve means; integer formats have only sample zero.
      info.resolveMode = t.format() == Format::R32Uint || t.format() == Format::RGBA32Uint ? VK_RESOLVE_MODE_SAMPLE_ZERO_BIT
                                                                                            : VK_RESOLVE_MODE_AVERAGE_BIT;
      info.resolveImageView = a.resolve_target->view_;
      info.resolveImageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    }
    colors.push_back(info);
    pass.color_formats_.push_back(t.format());
  }
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  if (desc.depth_attachment) {
    const auto& a = *desc.depth_attachment;
    if (!a.view) return bad("depth attachment has no view");
    const Texture& t = a.view->texture();
    if (!has(t.usage(), TextureUsage::DepthAttachment))
      return bad(weft::format("depth attachment texture '{}' lacks depth-attachment usage (has {})", t.label(), to_string(t.usage())));
    if (!check_size(*a.view))
      return bad(weft::format("depth attachment texture '{}' is {}x{}, the color attachments are {}x{}", t.label(),
                             t.size().width, t.size().height, extent->width, extent->height));
    depth.imageView = a.view->view_;
    depth.imageLayout = a.read_only ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL
                                    : VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    depth.loadOp = a.read_only ? VK_ATTACHMENT_LOAD_OP_LOAD : load_op(a.load);
    depth.storeOp = a.read_only ? VK_ATTACHMENT_STORE_OP_NONE : store_op(a.store);
    depth.clearValue.depthStencil = {a.clear_depth, 0};
    pass.depth_format_ = t.format();
    if (!check_samples(t, "depth attachment")) return pass;
    if (a.resolve_target) {
      const Texture& r = a.resolve_target->texture();
      if (auto problem = resolve_problem(t, *a.view, r, *a.resolve_target); !problem.empty())
        return bad(weft::format("depth attachment: {}", problem));
      const std::uint32_t modes = device_->info.limits.depth_resolve_modes;
      if (!(modes & (1u << std::uint32_t(a.resolve_mode))))
        return bad(weft::format("depth attachment '{}': resolve mode {} is not one adapter '{}' has", t.label(),
                                to_string(a.resolve_mode), device_->info.name));
      depth.resolveMode = VkResolveModeFlagBits(1u << std::uint32_t(a.resolve_mode));
      depth.resolveImageView = a.resolve_target->view_;
      depth.resolveImageLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    }
  }
  VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
  info.renderArea = {{0, 0}, {extent->width, extent->height}};
  info.layerCount = 1;
  info.colorAttachmentCount = std::uint32_t(colors.size());
  info.pColorAttachments = colors.data();
  info.pDepthAttachment = desc.depth_attachment ? &depth : nullptr;
  if (pass.depth_format_ == Format::Depth24PlusStencil8) info.pStencilAttachment = &depth;
  push_debug_group(desc.label.empty() ? "render pass" : desc.label);
  vkCmdBeginRendering(cmd_, &info);
  in_pass_ = true;
  pass.width_ = extent->width;
  pass.height_ = extent->height;
  pass.sample_count_ = samples ? samples->first : 1;
  // Default viewport and scissor: the whole attachment. Clip space is Vulkan's (y down, z in
  // [0, 1]); cameras build their projections for it.
  VkViewport viewport{0, 0, float(extent->width), float(extent->height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {extent->width, extent->height}};
  vkCmdSetViewport(cmd_, 0, 1, &viewport);
  vkCmdSetScissor(cmd_, 0, 1, &scissor);
  return pass;
}

RenderPassEncoder::RenderPassEncoder(RenderPassEncoder&& o) noexcept
    : encoder_(std::exchange(o.encoder_, nullptr)),
      pipeline_(o.pipeline_),
      groups_(o.groups_),
      dirty_groups_(o.dirty_groups_),
      index_bound_(o.index_bound_),
      width_(o.width_),
      height_(o.height_),
      color_formats_(std::move(o.color_formats_)),
      depth_format_(o.depth_format_),
      sample_count_(o.sample_count_),
      label_(std::move(o.label_)),
      ended_(std::exchange(o.ended_, true)) {}

RenderPassEncoder::~RenderPassEncoder() {
  if (encoder_ && !ended_) {
    encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}' was never ended", label_)});
    end();
  }
}

void RenderPassEncoder::set_pipeline(const RenderPipeline& pipeline) {
  if (ended_) return;
  if (pipeline.color_formats_ != color_formats_ || pipeline.depth_format_ != depth_format_) {
    std::string want, have;
    for (auto f : pipeline.color_formats_) want += std::string(to_string(f)) + " ";
    for (auto f : color_formats_) have += std::string(to_string(f)) + " ";
    encoder_->report_error({ErrorKind::InvalidArgument,
                            weft::format("render pass '{}': pipeline '{}' targets [{}] depth {} but the pass has [{}] depth {}",
                                        label_, pipeline.label(), want, to_string(pipeline.depth_format_), have,
                                        to_string(depth_format_))});
    return;
  }
  if (pipeline.sample_count_ != sample_count_) {
    encoder_->report_error({ErrorKind::InvalidArgument,
                            weft::format("render pass '{}': pipeline '{}' renders {} samples, the pass's attachments have {}",
                                         label_, pipeline.label(), pipeline.sample_count_, sample_count_)});
    return;
  }
  pipeline_ = &pipeline;
  vkCmdBindPipeline(encoder_->cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.pipeline_);
  dirty_groups_ = 0xff & ~0u;  // the new layout may differ: rebind everything at the next draw
  for (std::uint32_t i = 0; i < groups_.size(); ++i)
    if (!groups_[i]) dirty_groups_ &= ~(1u << i);
}

void RenderPassEncoder::set_bind_group(std::uint32_t index, const BindGroup& group) {
  if (ended_) return;
  if (index >= groups_.size())
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': bind group index {} >= 8 (group '{}')", label_, index, group.label())});
  groups_[index] = group.set_;
  dirty_groups_ |= 1u << index;
}

void RenderPassEncoder::set_vertex_buffer(std::uint32_t slot, const Buffer& buffer, std::uint64_t offset) {
  if (ended_) return;
  if (!has(buffer.usage(), BufferUsage::Vertex))
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': buffer '{}' set as vertex buffer lacks vertex usage (has {})",
                                                                           label_, buffer.label(), to_string(buffer.usage()))});
  VkDeviceSize off = offset;
  vkCmdBindVertexBuffers(encoder_->cmd_, slot, 1, &buffer.buffer_, &off);
}

void RenderPassEncoder::set_index_buffer(const Buffer& buffer, std::uint64_t offset) {
  if (ended_) return;
  if (!has(buffer.usage(), BufferUsage::Index))
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': buffer '{}' set as index buffer lacks index usage (has {})",
                                                                           label_, buffer.label(), to_string(buffer.usage()))});
  vkCmdBindIndexBuffer(encoder_->cmd_, buffer.buffer_, offset, VK_INDEX_TYPE_UINT32);
  index_bound_ = true;
}

void RenderPassEncoder::set_push_constants(std::span<const std::byte> data, std::uint32_t offset) {
  if (ended_) return;
  if (!pipeline_)
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': push constants before set_pipeline", label_)});
  if (offset + data.size() > pipeline_->push_constant_size_ || data.size() % 4 || offset % 4)
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': {} bytes of push constants at offset {} exceed pipeline '{}''s {} bytes (or are not 4-byte aligned)",
                                                                           label_, data.size(), offset, pipeline_->label(), pipeline_->push_constant_size_)});
  vkCmdPushConstants(encoder_->cmd_, pipeline_->layout_, VK_SHADER_STAGE_ALL, offset, std::uint32_t(data.size()), data.data());
}

void RenderPassEncoder::set_viewport(float x, float y, float width, float height) {
  if (ended_) return;
  VkViewport viewport{x, y, width, height, 0.0f, 1.0f};
  vkCmdSetViewport(encoder_->cmd_, 0, 1, &viewport);
}

void RenderPassEncoder::set_scissor_rect(std::int32_t x, std::int32_t y, std::uint32_t width, std::uint32_t height) {
  if (ended_) return;
  // Vulkan rejects negative offsets; clamp to the attachment as wgpu requires of callers.
  const std::int64_t x0 = std::clamp<std::int64_t>(x, 0, width_), y0 = std::clamp<std::int64_t>(y, 0, height_);
  const std::int64_t x1 = std::clamp<std::int64_t>(std::int64_t(x) + width, x0, width_);
  const std::int64_t y1 = std::clamp<std::int64_t>(std::int64_t(y) + height, y0, height_);
  VkRect2D scissor{{std::int32_t(x0), std::int32_t(y0)}, {std::uint32_t(x1 - x0), std::uint32_t(y1 - y0)}};
  vkCmdSetScissor(encoder_->cmd_, 0, 1, &scissor);
}

bool RenderPassEncoder::check_draw(std::string_view what) {
  if (ended_) return false;
  if (!pipeline_) {
    encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': {} without a pipeline", label_, what)});
    return false;
  }
  for (std::uint32_t i = 0; i < groups_.size(); ++i)
    if (dirty_groups_ & (1u << i))
      vkCmdBindDescriptorSets(encoder_->cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_->layout_, i, 1, &groups_[i], 0, nullptr);
  dirty_groups_ = 0;
  return true;
}

void RenderPassEncoder::draw(std::uint32_t vertex_count, std::uint32_t instance_count, std::uint32_t first_vertex,
                             std::uint32_t first_instance) {
  if (!check_draw("draw")) return;
  vkCmdDraw(encoder_->cmd_, vertex_count, instance_count, first_vertex, first_instance);
}

void RenderPassEncoder::draw_indexed(std::uint32_t index_count, std::uint32_t instance_count, std::uint32_t first_index,
                                     std::int32_t base_vertex, std::uint32_t first_instance) {
  if (!check_draw("draw_indexed")) return;
  if (!index_bound_)
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("render pass '{}': draw_indexed without an index buffer", label_)});
  vkCmdDrawIndexed(encoder_->cmd_, index_count, instance_count, first_index, base_vertex, first_instance);
}

void RenderPassEncoder::end() {
  if (ended_ || !encoder_) return;
  ended_ = true;
  vkCmdEndRendering(encoder_->cmd_);
  encoder_->pop_debug_group();
  encoder_->in_pass_ = false;
}

// ---- compute passes -------------------------------------------------------------------

ComputePassEncoder CommandEncoder::begin_compute_pass(std::string_view label) {
  ComputePassEncoder pass(this);
  pass.label_ = label;
  if (!check_outside_pass(weft::format("beginning compute pass '{}'", label))) {
    pass.ended_ = true;
    return pass;
  }
  push_debug_group(label.empty() ? "compute pass" : label);
  in_pass_ = true;
  return pass;
}

ComputePassEncoder::ComputePassEncoder(ComputePassEncoder&& o) noexcept
    : encoder_(std::exchange(o.encoder_, nullptr)),
      pipeline_(o.pipeline_),
      groups_(o.groups_),
      dirty_groups_(o.dirty_groups_),
      label_(std::move(o.label_)),
      ended_(std::exchange(o.ended_, true)) {}

ComputePassEncoder::~ComputePassEncoder() {
  if (encoder_ && !ended_) {
    encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}' was never ended", label_)});
    end();
  }
}

void ComputePassEncoder::set_pipeline(const ComputePipeline& pipeline) {
  if (ended_) return;
  pipeline_ = &pipeline;
  vkCmdBindPipeline(encoder_->cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline_);
  dirty_groups_ = 0;
  for (std::uint32_t i = 0; i < groups_.size(); ++i)
    if (groups_[i]) dirty_groups_ |= 1u << i;
}

void ComputePassEncoder::set_bind_group(std::uint32_t index, const BindGroup& group) {
  if (ended_) return;
  if (index >= groups_.size())
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': bind group index {} >= 8 (group '{}')", label_, index, group.label())});
  groups_[index] = group.set_;
  dirty_groups_ |= 1u << index;
}

void ComputePassEncoder::set_push_constants(std::span<const std::byte> data, std::uint32_t offset) {
  if (ended_) return;
  if (!pipeline_)
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': push constants before set_pipeline", label_)});
  if (offset + data.size() > pipeline_->push_constant_size_ || data.size() % 4 || offset % 4)
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': {} bytes of push constants at offset {} exceed pipeline '{}''s {} bytes (or are not 4-byte aligned)",
                                                                           label_, data.size(), offset, pipeline_->label(), pipeline_->push_constant_size_)});
  vkCmdPushConstants(encoder_->cmd_, pipeline_->layout_, VK_SHADER_STAGE_ALL, offset, std::uint32_t(data.size()), data.data());
}

bool ComputePassEncoder::ready_to_dispatch(std::string_view what) {
  if (ended_) return false;
  if (!pipeline_) {
    encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': {} without a pipeline", label_, what)});
    return false;
  }
  for (std::uint32_t i = 0; i < groups_.size(); ++i)
    if (dirty_groups_ & (1u << i))
      vkCmdBindDescriptorSets(encoder_->cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_->layout_, i, 1, &groups_[i], 0, nullptr);
  dirty_groups_ = 0;
  return true;
}

void ComputePassEncoder::dispatch(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  if (!ready_to_dispatch("dispatch")) return;
  if (x && y && z) vkCmdDispatch(encoder_->cmd_, x, y, z);
}

void ComputePassEncoder::dispatch_indirect(const Buffer& args, std::uint64_t offset) {
  if (ended_) return;
  if (!has(args.usage(), BufferUsage::Indirect))
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': buffer '{}' used for dispatch_indirect lacks indirect usage (has {})",
                                                                           label_, args.label(), to_string(args.usage()))});
  if (offset % 4 || offset + 12 > args.size())
    return encoder_->report_error({ErrorKind::InvalidArgument, weft::format("compute pass '{}': dispatch_indirect reads 12 bytes at offset {} of buffer '{}' ({} bytes; the offset must be a multiple of 4)",
                                                                           label_, offset, args.label(), args.size())});
  if (!ready_to_dispatch("dispatch_indirect")) return;
  vkCmdDispatchIndirect(encoder_->cmd_, args.buffer_, offset);
}

void ComputePassEncoder::end() {
  if (ended_ || !encoder_) return;
  ended_ = true;
  encoder_->pop_debug_group();
  encoder_->in_pass_ = false;
}

// ---- queue ----------------------------------------------------------------------------

Result<void> Queue::submit(CommandBuffer&& commands) {
  if (!commands.cmd_) return fail(ErrorKind::InvalidArgument, "submitting an empty command buffer");
  const VkCommandBuffer cmd = std::exchange(commands.cmd_, VK_NULL_HANDLE);
  return device_->submit(std::exchange(commands.pool_, VK_NULL_HANDLE), cmd, VK_NULL_HANDLE, commands.label());
}

Result<void> Queue::wait_idle() { return device_->wait_idle(); }

Result<void> Queue::write_buffer(const Buffer& buffer, std::uint64_t offset, std::span<const std::byte> data) {
  if (offset + data.size() > buffer.size())
    return fail(ErrorKind::InvalidArgument, "writing {} bytes at offset {} overflows buffer '{}' of {} bytes",
                data.size(), offset, buffer.label(), buffer.size());
  if (data.empty() || device_->declaring()) return {};  // a declaring device's: nothing will read it
  if (buffer.mapped_) {
    std::memcpy(buffer.mapped_ + offset, data.data(), data.size());
    return {};
  }
  if (!has(buffer.usage(), BufferUsage::CopyDst))
    return fail(ErrorKind::InvalidArgument, "writing buffer '{}' needs copy-dst or map-write usage (has {})",
                buffer.label(), to_string(buffer.usage()));
  auto stage = DeviceShared::make_buffer(device_, {buffer.label() + " (staging)", data.size(), BufferUsage::MapWrite}, {});
  if (!stage) return std::unexpected(stage.error());
  std::memcpy(stage->mapped_, data.data(), data.size());
  auto encoder = DeviceShared::make_encoder(device_, "write_buffer");
  if (!encoder) return std::unexpected(encoder.error());
  encoder->copy_buffer_to_buffer(*stage, 0, buffer, offset, data.size());
  // Make the copy visible to whatever reads the buffer in later submissions.
  const BufferBarrier b{&buffer, Access::CopyDst, Access::ShaderRead};
  const BufferBarrier rest[] = {b, {&buffer, Access::CopyDst, Access::VertexBuffer}, {&buffer, Access::CopyDst, Access::IndexBuffer},
                                {&buffer, Access::CopyDst, Access::UniformRead}, {&buffer, Access::CopyDst, Access::CopySrc}};
  encoder->barrier({}, rest);
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = submit(std::move(*commands)); !ok) return ok;
  return wait_idle();
}

Result<void> Queue::write_texture(const Texture& texture, std::span<const std::byte> data, std::uint32_t mip,
                                  Access after) {
  if (mip >= texture.descriptor().mip_level_count)
    return fail(ErrorKind::InvalidArgument, "texture '{}' has no mip {}", texture.label(), mip);
  const std::uint64_t bytes = mip_bytes(texture, mip);
  if (data.size() != bytes)
    return fail(ErrorKind::InvalidArgument, "writing texture '{}' mip {}: got {} bytes, expected {} ({}x{} {})",
                texture.label(), mip, data.size(), bytes, mip_extent(texture, mip).width,
                mip_extent(texture, mip).height, to_string(texture.format()));
  if (!has(texture.usage(), TextureUsage::CopyDst))
    return fail(ErrorKind::InvalidArgument, "writing texture '{}' needs copy-dst usage (has {})", texture.label(),
                to_string(texture.usage()));
  if (device_->declaring()) return {};  // nothing will read it
  auto stage = DeviceShared::make_buffer(device_, {texture.label() + " (staging)", bytes, BufferUsage::MapWrite}, {});
  if (!stage) return std::unexpected(stage.error());
  std::memcpy(stage->mapped_, data.data(), data.size());
  auto encoder = DeviceShared::make_encoder(device_, "write_texture");
  if (!encoder) return std::unexpected(encoder.error());
  encoder->transition(texture, Access::CopyDst);
  encoder->copy_buffer_to_texture(*stage, 0, texture, mip);
  encoder->transition(texture, after);
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = submit(std::move(*commands)); !ok) return ok;
  return wait_idle();
}

Result<void> Queue::write_texture_levels(const Texture& texture, std::span<const std::span<const std::byte>> levels,
                                         Access after) {
  if (levels.empty() || levels.size() > texture.descriptor().mip_level_count)
    return fail(ErrorKind::InvalidArgument, "writing texture '{}': {} levels given, it has {} mips", texture.label(),
                levels.size(), texture.descriptor().mip_level_count);
  if (!has(texture.usage(), TextureUsage::CopyDst))
    return fail(ErrorKind::InvalidArgument, "writing texture '{}' needs copy-dst usage (has {})", texture.label(),
                to_string(texture.usage()));
  std::vector<std::uint64_t> offsets;
  std::uint64_t total = 0;
  for (std::uint32_t mip = 0; mip < levels.size(); ++mip) {
    const std::uint64_t bytes = mip_bytes(texture, mip);
    if (levels[mip].size() != bytes)
      return fail(ErrorKind::InvalidArgument, "writing texture '{}' mip {}: got {} bytes, expected {} ({}x{} {})",
                  texture.label(), mip, levels[mip].size(), bytes, mip_extent(texture, mip).width,
                  mip_extent(texture, mip).height, to_string(texture.format()));
    total = (total + 15) & ~std::uint64_t(15);  // texel-aligned offsets for every format
    offsets.push_back(total);
    total += bytes;
  }
  if (device_->declaring()) return {};
  auto stage = DeviceShared::make_buffer(device_, {texture.label() + " (staging)", total, BufferUsage::MapWrite}, {});
  if (!stage) return std::unexpected(stage.error());
  for (std::uint32_t mip = 0; mip < levels.size(); ++mip)
    std::memcpy(stage->mapped_ + offsets[mip], levels[mip].data(), levels[mip].size());
  auto encoder = DeviceShared::make_encoder(device_, "write_texture_levels");
  if (!encoder) return std::unexpected(encoder.error());
  encoder->transition(texture, Access::CopyDst);
  for (std::uint32_t mip = 0; mip < levels.size(); ++mip) encoder->copy_buffer_to_texture(*stage, offsets[mip], texture, mip);
  encoder->transition(texture, after);
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = submit(std::move(*commands)); !ok) return ok;
  return wait_idle();
}

Result<std::vector<std::byte>> Queue::read_texture(const Texture& texture, std::uint32_t mip) {
  if (!has(texture.usage(), TextureUsage::CopySrc))
    return fail(ErrorKind::InvalidArgument, "reading back texture '{}' needs copy-src usage (has {})", texture.label(),
                to_string(texture.usage()));
  if (mip >= texture.descriptor().mip_level_count)
    return fail(ErrorKind::InvalidArgument, "texture '{}' has no mip {}", texture.label(), mip);
  const std::uint64_t bytes = mip_bytes(texture, mip);
  auto stage = DeviceShared::make_buffer(device_, {texture.label() + " (readback)", bytes, BufferUsage::MapRead}, {});
  if (!stage) return std::unexpected(stage.error());
  auto encoder = DeviceShared::make_encoder(device_, "read_texture");
  if (!encoder) return std::unexpected(encoder.error());
  encoder->transition(texture, Access::CopySrc);
  encoder->copy_texture_to_buffer(texture, *stage, 0, mip);
  const BufferBarrier host{&*stage, Access::CopyDst, Access::HostRead};
  encoder->barrier({}, std::span(&host, 1));
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = submit(std::move(*commands)); !ok) return std::unexpected(ok.error());
  if (auto ok = wait_idle(); !ok) return std::unexpected(ok.error());
  std::vector<std::byte> out(bytes);
  std::memcpy(out.data(), stage->mapped_, bytes);
  return out;
}

Result<std::vector<std::byte>> Queue::read_buffer(const Buffer& buffer, std::uint64_t offset, std::uint64_t size) {
  const std::uint64_t n = size ? size : buffer.size() - std::min(offset, buffer.size());
  if (offset + n > buffer.size() || n == 0)
    return fail(ErrorKind::InvalidArgument, "reading [{}, {}) of buffer '{}' of {} bytes", offset, offset + n,
                buffer.label(), buffer.size());
  if (buffer.mapped_) {
    if (auto ok = wait_idle(); !ok) return std::unexpected(ok.error());
    return std::vector<std::byte>(buffer.mapped_ + offset, buffer.mapped_ + offset + n);
  }
  auto stage = DeviceShared::make_buffer(device_, {buffer.label() + " (readback)", n, BufferUsage::MapRead}, {});
  if (!stage) return std::unexpected(stage.error());
  auto encoder = DeviceShared::make_encoder(device_, "read_buffer");
  if (!encoder) return std::unexpected(encoder.error());
  // Whatever wrote the buffer before (shader, copy) must finish before the copy reads it.
  const BufferBarrier before[] = {{&buffer, Access::StorageWrite, Access::CopySrc}, {&buffer, Access::CopyDst, Access::CopySrc}};
  encoder->barrier({}, before);
  encoder->copy_buffer_to_buffer(buffer, offset, *stage, 0, n);
  const BufferBarrier host{&*stage, Access::CopyDst, Access::HostRead};
  encoder->barrier({}, std::span(&host, 1));
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = submit(std::move(*commands)); !ok) return std::unexpected(ok.error());
  if (auto ok = wait_idle(); !ok) return std::unexpected(ok.error());
  return std::vector<std::byte>(stage->mapped_, stage->mapped_ + n);
}

}  // namespace weft::gpu

namespace weft::gpu::detail {

Result<CommandEncoder> DeviceShared::make_encoder(const std::shared_ptr<DeviceShared>& self, std::string_view label) {
  if (self->declaring())
    return fail(ErrorKind::Unsupported, "command encoder '{}': device '{}' only declares; nothing can be recorded or "
                "submitted on it", label, self->info.name);
  auto pool = self->thread_pool();
  if (!pool) return with_context(weft::format("creating command encoder '{}'", label), pool.error());
  CommandEncoder encoder;
  encoder.device_ = self;
  encoder.label_ = label;
  encoder.pool_ = *pool;
  VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = encoder.pool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  if (VkResult r = vkAllocateCommandBuffers(self->device, &alloc, &encoder.cmd_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating command encoder '{}'", label)));
  self->set_name(VK_OBJECT_TYPE_COMMAND_BUFFER, std::uint64_t(encoder.cmd_), label);
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(encoder.cmd_, &begin);
  return encoder;
}

}  // namespace weft::gpu::detail
