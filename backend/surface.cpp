// Presentation: a Surface over an X11 window and its swapchain, in wgpu's shape. Frames are
// synchronous on weft's queue, so images are acquired with a fence the host waits on (every
// later submission is then ordered after the acquire), and present() signals one semaphore
// per swapchain image from an otherwise empty submission: a signal waits for all work
// submitted before it, whatever pass last wrote the image.
module;
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <vulkan/vulkan.h>
// vulkan_xlib.h needs three Xlib types; declaring them here keeps Xlib's macros (None,
// Status, Bool) out of this unit.
typedef struct _XDisplay Display;
typedef unsigned long Window;
typedef unsigned long VisualID;
#include <vulkan/vulkan_xlib.h>
module weft.gpu;
import weft.core;

namespace weft::gpu {
using namespace detail;

std::string_view to_string(PresentMode mode) {
  switch (mode) {
    case PresentMode::Fifo: return "fifo";
    case PresentMode::Mailbox: return "mailbox";
    case PresentMode::Immediate: return "immediate";
  }
  return "?";
}

namespace {
VkPresentModeKHR to_vk(PresentMode mode) {
  switch (mode) {
    case PresentMode::Mailbox: return VK_PRESENT_MODE_MAILBOX_KHR;
    case PresentMode::Immediate: return VK_PRESENT_MODE_IMMEDIATE_KHR;
    case PresentMode::Fifo: break;
  }
  return VK_PRESENT_MODE_FIFO_KHR;
}

std::optional<Format> from_vk(VkFormat f) {
  for (std::uint8_t i = 1; i <= std::uint8_t(Format::Depth24PlusStencil8); ++i)
    if (detail::to_vk(Format(i)) == f) return Format(i);
  return std::nullopt;
}

TextureUsage from_vk_usage(VkImageUsageFlags u) {
  TextureUsage out = TextureUsage::None;
  if (u & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) out = out | TextureUsage::CopySrc;
  if (u & VK_IMAGE_USAGE_TRANSFER_DST_BIT) out = out | TextureUsage::CopyDst;
  if (u & VK_IMAGE_USAGE_SAMPLED_BIT) out = out | TextureUsage::Sampled;
  if (u & VK_IMAGE_USAGE_STORAGE_BIT) out = out | TextureUsage::Storage;
  if (u & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT) out = out | TextureUsage::ColorAttachment;
  return out;
}
}  // namespace

struct Surface::State {
  std::shared_ptr<InstanceShared> instance;
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  std::shared_ptr<DeviceShared> device;
  VkSwapchainKHR swapchain = VK_NULL_HANDLE;
  VkExtent2D extent{0, 0};
  std::vector<Texture> textures;
  std::vector<VkSemaphore> rendered;  // one per image: signalled by present()'s submission
  VkFence acquired_fence = VK_NULL_HANDLE;
  std::optional<std::uint32_t> acquired;
  bool remake = false;  // the last present() or acquire said the swapchain is suboptimal

  // vkDeviceWaitIdle uses every queue of the device: under the queue lock, since another
  // thread (the viewer's render thread) may be submitting on it.
  void wait_device_idle() {
    std::lock_guard lock(device->mutex);
    vkDeviceWaitIdle(device->device);
  }

  void destroy_swapchain() {
    if (!device) return;
    wait_device_idle();
    textures.clear();
    for (auto s : rendered) vkDestroySemaphore(device->device, s, nullptr);
    rendered.clear();
    if (swapchain) vkDestroySwapchainKHR(device->device, swapchain, nullptr);
    swapchain = VK_NULL_HANDLE;
    extent = {0, 0};
    acquired.reset();
  }
  ~State() {
    destroy_swapchain();
    if (device && acquired_fence) vkDestroyFence(device->device, acquired_fence, nullptr);
    if (surface) vkDestroySurfaceKHR(instance->instance, surface, nullptr);
  }
  Result<VkSurfaceCapabilitiesKHR> surface_capabilities() const {
    VkSurfaceCapabilitiesKHR caps{};
    if (VkResult r = vkGetPhysicalDeviceSurfaceCapabilitiesKHR(device->physical, surface, &caps); r != VK_SUCCESS)
      return std::unexpected(vk_error(r, "reading the window surface's capabilities"));
    return caps;
  }
  // The size a swapchain would have now: the window's, where the window system says it.
  static VkExtent2D window_extent(const VkSurfaceCapabilitiesKHR& caps, const SurfaceConfiguration& config) {
    if (caps.currentExtent.width != 0xFFFFFFFFu) return caps.currentExtent;
    return {std::clamp(config.width, caps.minImageExtent.width, caps.maxImageExtent.width),
            std::clamp(config.height, caps.minImageExtent.height, caps.maxImageExtent.height)};
  }
  Result<void> make_swapchain(const SurfaceConfiguration& config);
};

Result<Surface> Instance::create_surface(const NativeWindow& window) const {
  if (!shared_->presentation)
    return fail(ErrorKind::InvalidArgument,
                "create_surface needs an instance made with InstanceDescriptor::presentation = true");
  if (!window.x11_display || !window.x11_window)
    return fail(ErrorKind::InvalidArgument, "create_surface: the native window has no X11 display or window");
  Surface surface;
  surface.state_ = std::make_unique<Surface::State>();
  surface.state_->instance = shared_;
  VkXlibSurfaceCreateInfoKHR info{VK_STRUCTURE_TYPE_XLIB_SURFACE_CREATE_INFO_KHR};
  info.dpy = static_cast<Display*>(window.x11_display);
  info.window = Window(window.x11_window);
  if (VkResult r = vkCreateXlibSurfaceKHR(shared_->instance, &info, nullptr, &surface.state_->surface); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, "creating a Vulkan surface for the X11 window"));
  return surface;
}

Surface::Surface(Surface&&) noexcept = default;
Surface& Surface::operator=(Surface&&) noexcept = default;
Surface::~Surface() = default;

Result<SurfaceCapabilities> Surface::capabilities(const Device& device) const {
  const auto& d = *device.shared_;
  if (!d.swapchain)
    return fail(ErrorKind::Unsupported, "adapter '{}' cannot present: it lacks VK_KHR_swapchain", d.info.name);
  VkBool32 supported = VK_FALSE;
  vkGetPhysicalDeviceSurfaceSupportKHR(d.physical, d.queue_family, state_->surface, &supported);
  if (!supported)
    return fail(ErrorKind::Unsupported, "adapter '{}' cannot present to this window from its queue", d.info.name);
  SurfaceCapabilities out;
  std::uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(d.physical, state_->surface, &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(d.physical, state_->surface, &count, formats.data());
  for (const auto& f : formats)
    if (auto format = from_vk(f.format); format && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR)
      out.formats.push_back(*format);
  vkGetPhysicalDeviceSurfacePresentModesKHR(d.physical, state_->surface, &count, nullptr);
  std::vector<VkPresentModeKHR> modes(count);
  vkGetPhysicalDeviceSurfacePresentModesKHR(d.physical, state_->surface, &count, modes.data());
  for (auto mode : {PresentMode::Fifo, PresentMode::Mailbox, PresentMode::Immediate})
    if (std::find(modes.begin(), modes.end(), to_vk(mode)) != modes.end()) out.present_modes.push_back(mode);
  VkSurfaceCapabilitiesKHR caps{};
  vkGetPhysicalDeviceSurfaceCapabilitiesKHR(d.physical, state_->surface, &caps);
  out.usages = from_vk_usage(caps.supportedUsageFlags);
  return out;
}

Result<void> Surface::configure(Device& device, const SurfaceConfiguration& config) {
  auto caps = capabilities(device);
  if (!caps) return std::unexpected(caps.error());
  if (std::find(caps->formats.begin(), caps->formats.end(), config.format) == caps->formats.end()) {
    std::string offered;
    for (auto f : caps->formats) offered += (offered.empty() ? "" : ", ") + std::string(to_string(f));
    return fail(ErrorKind::Unsupported, "the window cannot show format {} (it offers {})", to_string(config.format),
                offered.empty() ? "none weft names" : offered);
  }
  if (!has(caps->usages, config.usage))
    return fail(ErrorKind::Unsupported, "the window's textures cannot take usage {} (they allow {})",
                to_string(config.usage), to_string(caps->usages));
  if (state_->device && state_->device != device.shared_) {
    state_->destroy_swapchain();
    if (state_->acquired_fence) vkDestroyFence(state_->device->device, state_->acquired_fence, nullptr);
    state_->acquired_fence = VK_NULL_HANDLE;
  }
  state_->device = device.shared_;
  if (!state_->acquired_fence) {
    VkFenceCreateInfo info{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    if (VkResult r = vkCreateFence(device.shared_->device, &info, nullptr, &state_->acquired_fence); r != VK_SUCCESS)
      return std::unexpected(vk_error(r, "creating the surface's acquire fence"));
  }
  config_ = config;
  if (std::find(caps->present_modes.begin(), caps->present_modes.end(), config.present_mode) == caps->present_modes.end())
    config_.present_mode = PresentMode::Fifo;
  return state_->make_swapchain(config_);
}

Result<void> Surface::State::make_swapchain(const SurfaceConfiguration& config) {
  auto caps = surface_capabilities();
  if (!caps) return std::unexpected(caps.error());
  const VkExtent2D size = window_extent(*caps, config);
  VkSwapchainKHR old = swapchain;
  wait_device_idle();
  textures.clear();
  for (auto s : rendered) vkDestroySemaphore(device->device, s, nullptr);
  rendered.clear();
  acquired.reset();
  remake = false;
  if (size.width == 0 || size.height == 0) {  // minimised: no swapchain until it has an area again
    if (old) vkDestroySwapchainKHR(device->device, old, nullptr);
    swapchain = VK_NULL_HANDLE;
    extent = size;
    return {};
  }
  VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  info.surface = surface;
  info.minImageCount = caps->maxImageCount ? std::min(caps->minImageCount + 1, caps->maxImageCount)
                                           : caps->minImageCount + 1;
  info.imageFormat = detail::to_vk(config.format);
  info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
  info.imageExtent = size;
  info.imageArrayLayers = 1;
  info.imageUsage = detail::to_vk(config.usage);
  info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.preTransform = caps->currentTransform;
  info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  for (auto bit : {VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR, VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR,
                   VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR})
    if (caps->supportedCompositeAlpha & bit) {
      info.compositeAlpha = bit;
      break;
    }
  info.presentMode = to_vk(config.present_mode);
  info.clipped = VK_TRUE;
  info.oldSwapchain = old;
  VkSwapchainKHR made = VK_NULL_HANDLE;
  const VkResult r = vkCreateSwapchainKHR(device->device, &info, nullptr, &made);
  if (old) vkDestroySwapchainKHR(device->device, old, nullptr);
  swapchain = VK_NULL_HANDLE;
  extent = {0, 0};
  if (r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating a {}x{} swapchain", size.width, size.height)));
  swapchain = made;
  extent = size;

  std::uint32_t count = 0;
  vkGetSwapchainImagesKHR(device->device, swapchain, &count, nullptr);
  std::vector<VkImage> images(count);
  vkGetSwapchainImagesKHR(device->device, swapchain, &count, images.data());
  textures.reserve(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    Texture t;
    t.device_ = device;
    t.image_ = images[i];
    t.owns_image_ = false;
    t.desc_ = {.label = weft::format("surface texture {}", i), .size = {size.width, size.height, 1},
               .format = config.format, .usage = config.usage};
    device->set_name(VK_OBJECT_TYPE_IMAGE, std::uint64_t(images[i]), t.desc_.label);
    auto view = t.create_view({0, 1});
    if (!view) return std::unexpected(view.error());
    t.default_view_ = std::make_unique<TextureView>(std::move(*view));
    t.fix_view_back_pointer();
    textures.push_back(std::move(t));
    VkSemaphoreCreateInfo s{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    VkSemaphore semaphore = VK_NULL_HANDLE;
    if (VkResult sr = vkCreateSemaphore(device->device, &s, nullptr, &semaphore); sr != VK_SUCCESS)
      return std::unexpected(vk_error(sr, "creating a present semaphore"));
    rendered.push_back(semaphore);
  }
  return {};
}

Result<SurfaceTexture> Surface::get_current_texture() {
  auto& s = *state_;
  if (!s.device) return fail(ErrorKind::InvalidArgument, "get_current_texture before configure");
  if (s.acquired) return fail(ErrorKind::InvalidArgument, "get_current_texture twice without present");
  auto caps = s.surface_capabilities();
  if (!caps) return std::unexpected(caps.error());
  const VkExtent2D now = State::window_extent(*caps, config_);
  SurfaceStatus status = SurfaceStatus::Good;
  // Resizes are caught here rather than by OUT_OF_DATE, which X11 drivers need not report.
  if (s.remake || !s.swapchain || now.width != s.extent.width || now.height != s.extent.height) {
    if (now.width == 0 || now.height == 0) {
      if (s.swapchain) {
        if (auto ok = s.make_swapchain(config_); !ok) return std::unexpected(ok.error());
      }
      return SurfaceTexture{nullptr, SurfaceStatus::Minimized};
    }
    if (auto ok = s.make_swapchain(config_); !ok) return std::unexpected(ok.error());
    status = SurfaceStatus::Reconfigured;
  }
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::uint32_t index = 0;
    const VkResult r = vkAcquireNextImageKHR(s.device->device, s.swapchain, UINT64_MAX, VK_NULL_HANDLE,
                                             s.acquired_fence, &index);
    if (r == VK_ERROR_OUT_OF_DATE_KHR && attempt == 0) {
      if (auto ok = s.make_swapchain(config_); !ok) return std::unexpected(ok.error());
      if (!s.swapchain) return SurfaceTexture{nullptr, SurfaceStatus::Minimized};
      status = SurfaceStatus::Reconfigured;
      continue;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
      return std::unexpected(vk_error(r, "acquiring the next window texture"));
    if (r == VK_SUBOPTIMAL_KHR) s.remake = true;  // use this one, remake before the next
    vkWaitForFences(s.device->device, 1, &s.acquired_fence, VK_TRUE, UINT64_MAX);
    vkResetFences(s.device->device, 1, &s.acquired_fence);
    s.acquired = index;
    const Texture& texture = s.textures[index];
    texture.state_ = Access::Undefined;  // what was presented before is not kept
    return SurfaceTexture{&texture, status};
  }
  return fail(ErrorKind::Device, "the window's swapchain stayed out of date after it was remade");
}

Result<void> Surface::present() {
  auto& s = *state_;
  if (!s.acquired) return fail(ErrorKind::InvalidArgument, "present without a texture from get_current_texture");
  const std::uint32_t index = *std::exchange(s.acquired, std::nullopt);
  const Texture& texture = s.textures[index];
  auto encoder = DeviceShared::make_encoder(s.device, "present");
  if (!encoder) return std::unexpected(encoder.error());
  if (texture.state() != Access::Present) encoder->transition(texture, Access::Present);
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());

  const VkCommandBuffer cmd = std::exchange(commands->cmd_, VK_NULL_HANDLE);
  if (auto ok = s.device->submit(std::exchange(commands->pool_, VK_NULL_HANDLE), cmd, s.rendered[index],
                                 "the present transition");
      !ok)
    return ok;

  VkPresentInfoKHR info{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  info.waitSemaphoreCount = 1;
  info.pWaitSemaphores = &s.rendered[index];
  info.swapchainCount = 1;
  info.pSwapchains = &s.swapchain;
  info.pImageIndices = &index;
  VkResult r;
  {
    std::lock_guard lock(s.device->mutex);  // the queue is shared with other threads' submits
    r = vkQueuePresentKHR(s.device->queue, &info);
  }
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
    s.remake = true;
    return {};
  }
  if (r != VK_SUCCESS) return std::unexpected(vk_error(r, "presenting to the window"));
  return {};
}

}  // namespace weft::gpu
