// Instance (with the validation layer and its message log), adapter choice, device creation.
module;
#include <expected>
#include <optional>
#include <span>
#include <utility>
#include <cstdint>
#include <string_view>
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <thread>
#include <string>
#include <vector>
#include <vulkan/vulkan.h>
module weft.gpu;
import weft.core;

namespace weft::gpu::detail {

struct MessageLog {
  std::mutex mutex;
  std::vector<std::string> messages;
  std::size_t total = 0;
};

InstanceShared::~InstanceShared() {
  if (messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance, messenger, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

}  // namespace weft::gpu::detail

namespace weft::gpu {
using namespace detail;

namespace {

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* log = static_cast<MessageLog*>(user);
  std::string text = weft::format("[{}] {}", severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning",
                                 data && data->pMessage ? data->pMessage : "(no message)");
  {
    std::lock_guard lock(log->mutex);
    log->messages.push_back(text);
    ++log->total;
  }
  weft::log::warn("validation: " + text);
  return VK_FALSE;
}

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

bool layer_available(const char* name) {
  std::uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  return std::any_of(layers.begin(), layers.end(), [&](auto& l) { return std::strcmp(l.layerName, name) == 0; });
}

bool extension_available(const char* name) {
  std::uint32_t count = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> exts(count);
  vkEnumerateInstanceExtensionProperties(nullptr, &count, exts.data());
  return std::any_of(exts.begin(), exts.end(), [&](auto& e) { return std::strcmp(e.extensionName, name) == 0; });
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// VK_KHR_cooperative_matrix's feature struct (Vulkan 1.3.255): this machine's headers are
// 1.3.239, so its sType and layout are spelled out here, from the registry.
constexpr auto kCooperativeMatrixFeaturesType = VkStructureType(1000506000);
struct CooperativeMatrixFeatures {
  VkStructureType sType = kCooperativeMatrixFeaturesType;
  void* pNext = nullptr;
  VkBool32 cooperativeMatrix = VK_FALSE;
  VkBool32 cooperativeMatrixRobustBufferAccess = VK_FALSE;
};

AdapterFeatures detect_features(VkPhysicalDevice pd) {
  AdapterFeatures f;
  std::uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> exts(count);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &count, exts.data());
  const bool has_extension = std::any_of(exts.begin(), exts.end(), [](const VkExtensionProperties& e) {
    return std::strcmp(e.extensionName, "VK_KHR_cooperative_matrix") == 0;
  });
  if (has_extension) {
    CooperativeMatrixFeatures coop;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &coop};
    vkGetPhysicalDeviceFeatures2(pd, &features);
    f.cooperative_matrix = coop.cooperativeMatrix == VK_TRUE;
  }
  return f;
}

AdapterInfo describe(VkPhysicalDevice pd) {
  VkPhysicalDeviceDepthStencilResolveProperties resolve{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DEPTH_STENCIL_RESOLVE_PROPERTIES};
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES, &resolve};
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &driver};
  vkGetPhysicalDeviceProperties2(pd, &props);
  const auto& p = props.properties;
  AdapterInfo info;
  info.name = p.deviceName;
  info.driver = driver.driverName;
  info.driver_info = driver.driverInfo;
  info.api_version = p.apiVersion;
  switch (p.deviceType) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: info.type = AdapterType::DiscreteGpu; break;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: info.type = AdapterType::IntegratedGpu; break;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: info.type = AdapterType::VirtualGpu; break;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: info.type = AdapterType::Cpu; break;
    default: info.type = AdapterType::Other; break;
  }
  VkPhysicalDeviceMemoryProperties mem{};
  vkGetPhysicalDeviceMemoryProperties(pd, &mem);
  for (std::uint32_t i = 0; i < mem.memoryHeapCount; ++i)
    if (mem.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) info.device_local_bytes += mem.memoryHeaps[i].size;
  Limits& l = info.limits;
  l.max_texture_dimension_2d = p.limits.maxImageDimension2D;
  l.max_push_constant_size = p.limits.maxPushConstantsSize;
  l.max_bound_descriptor_sets = p.limits.maxBoundDescriptorSets;
  for (int i = 0; i < 3; ++i) l.max_compute_workgroup_size[i] = p.limits.maxComputeWorkGroupSize[i];
  l.max_compute_invocations = p.limits.maxComputeWorkGroupInvocations;
  l.max_storage_buffer_range = p.limits.maxStorageBufferRange;
  l.min_uniform_buffer_offset_alignment = p.limits.minUniformBufferOffsetAlignment;
  l.min_storage_buffer_offset_alignment = p.limits.minStorageBufferOffsetAlignment;
  l.timestamp_period_ns = p.limits.timestampPeriod;
  l.timestamps = p.limits.timestampComputeAndGraphics;
  l.max_compute_shared_memory = p.limits.maxComputeSharedMemorySize;
  l.color_sample_counts = p.limits.framebufferColorSampleCounts;
  l.depth_sample_counts = p.limits.framebufferDepthSampleCounts;
  l.sampled_color_sample_counts = p.limits.sampledImageColorSampleCounts;
  l.sampled_depth_sample_counts = p.limits.sampledImageDepthSampleCounts;
  // VkResolveModeFlagBits: SAMPLE_ZERO 1, AVERAGE 2, MIN 4, MAX 8 -- ResolveMode's order.
  l.depth_resolve_modes = resolve.supportedDepthResolveModes & 0xF;
  VkPhysicalDeviceFeatures supported{};
  vkGetPhysicalDeviceFeatures(pd, &supported);
  l.max_sampler_anisotropy = supported.samplerAnisotropy ? p.limits.maxSamplerAnisotropy : 1.0f;
  // lavapipe (Mesa 25.0) returns black through an anisotropic sampler where the texture
  // coordinates have zero derivatives -- a mesh with one UV everywhere, a texel pinned by its
  // UVs (test_msaa: "trilinear and anisotropic samplers read a constant mip chain"); weft keeps
  // anisotropy off there (trilinear only) rather than draw such meshes black.
  if (driver.driverID == VK_DRIVER_ID_MESA_LLVMPIPE) l.max_sampler_anisotropy = 1.0f;
  info.features = detect_features(pd);
  info.features.sample_rate_shading = supported.sampleRateShading == VK_TRUE;
  return info;
}

int preference_rank(AdapterType t, PowerPreference pref) {
  if (pref == PowerPreference::Cpu) return t == AdapterType::Cpu ? 0 : 1;
  switch (t) {
    case AdapterType::DiscreteGpu: return 0;
    case AdapterType::IntegratedGpu: return 1;
    case AdapterType::VirtualGpu: return 2;
    case AdapterType::Other: return 3;
    case AdapterType::Cpu: return 4;
  }
  return 5;
}

}  // namespace

Result<Instance> Instance::create(const InstanceDescriptor& desc) {
  auto shared = std::make_shared<InstanceShared>();
  shared->log = std::make_shared<MessageLog>();
  const bool want_validation = desc.validation || env_flag("WEFT_VALIDATION");
  const bool want_sync = desc.synchronization_validation || env_flag("WEFT_SYNC_VALIDATION");
  const char* validation_layer = "VK_LAYER_KHRONOS_validation";
  if (want_validation && !layer_available(validation_layer))
    return fail(ErrorKind::NotFound,
                "validation was requested but {} is not installed (Debian: apt install vulkan-validationlayers)",
                validation_layer);
  shared->debug_utils = extension_available(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (want_validation) layers.push_back(validation_layer);
  if (shared->debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (desc.presentation) {
    for (const char* name : {"VK_KHR_surface", "VK_KHR_xlib_surface"}) {
      if (!extension_available(name))
        return fail(ErrorKind::Unsupported, "presentation needs the Vulkan instance extension {}, which no installed "
                                            "driver offers (headless rendering does not need it)", name);
      extensions.push_back(name);
    }
  }

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = desc.application_name.c_str();
  app.pEngineName = "weft";
  app.apiVersion = VK_API_VERSION_1_3;

  std::vector<VkValidationFeatureEnableEXT> enables;
  if (want_sync) enables.push_back(VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT);
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = std::uint32_t(enables.size());
  features.pEnabledValidationFeatures = enables.data();

  VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pNext = want_validation && !enables.empty() ? &features : nullptr;
  info.pApplicationInfo = &app;
  info.enabledLayerCount = std::uint32_t(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = std::uint32_t(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  if (VkResult r = vkCreateInstance(&info, nullptr, &shared->instance); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, "vkCreateInstance"));
  shared->validation = want_validation;
  shared->presentation = desc.presentation;

  if (want_validation && shared->debug_utils) {
    VkDebugUtilsMessengerCreateInfoEXT m{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    m.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    m.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    m.pfnUserCallback = on_validation_message;
    m.pUserData = shared->log.get();
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(shared->instance, "vkCreateDebugUtilsMessengerEXT"));
    if (!create || create(shared->instance, &m, nullptr, &shared->messenger) != VK_SUCCESS)
      return fail(ErrorKind::Device, "could not create the validation message callback");
  }
  return Instance(std::move(shared));
}

Instance::Instance(Instance&&) noexcept = default;
Instance& Instance::operator=(Instance&&) noexcept = default;
Instance::~Instance() = default;

bool Instance::validation_enabled() const { return shared_->validation; }
bool Instance::presentation_enabled() const { return shared_->presentation; }

std::vector<std::string> Instance::take_validation_messages() const {
  std::lock_guard lock(shared_->log->mutex);
  return std::exchange(shared_->log->messages, {});
}

std::size_t Instance::validation_message_count() const {
  std::lock_guard lock(shared_->log->mutex);
  return shared_->log->total;
}

std::vector<AdapterInfo> Instance::enumerate_adapters() const {
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(shared_->instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(shared_->instance, &count, devices.data());
  std::vector<AdapterInfo> out;
  for (auto pd : devices) out.push_back(describe(pd));
  return out;
}

Result<Adapter> Instance::request_adapter(const AdapterOptions& options) const {
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(shared_->instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(shared_->instance, &count, devices.data());

  AdapterOptions opts = options;
  if (const char* env = std::getenv("WEFT_ADAPTER"); env && *env) {
    std::string v = lower(env);
    if (v == "cpu") opts.preference = PowerPreference::Cpu;
    else if (v == "gpu") opts.preference = PowerPreference::HighPerformance;
    else opts.name_contains = v;
  }

  std::vector<std::pair<VkPhysicalDevice, AdapterInfo>> candidates;
  std::string names;
  for (auto pd : devices) {
    AdapterInfo info = describe(pd);
    names += (names.empty() ? "" : ", ") + info.name;
    if (VK_API_VERSION_MINOR(info.api_version) < 3 && VK_API_VERSION_MAJOR(info.api_version) == 1) continue;
    if (!opts.name_contains.empty() && lower(info.name).find(lower(opts.name_contains)) == std::string::npos) continue;
    candidates.emplace_back(pd, std::move(info));
  }
  if (candidates.empty()) {
    if (devices.empty())
      return fail(ErrorKind::NotFound,
                  "no Vulkan adapter found (install Mesa's lavapipe: apt install mesa-vulkan-drivers)");
    return fail(ErrorKind::NotFound, "no Vulkan 1.3 adapter matches{} (adapters: {})",
                opts.name_contains.empty() ? std::string() : " '" + opts.name_contains + "'", names);
  }
  // The best-ranked adapter; ties keep the driver's enumeration order.
  auto best = std::min_element(candidates.begin(), candidates.end(), [&](auto& a, auto& b) {
    return preference_rank(a.second.type, opts.preference) < preference_rank(b.second.type, opts.preference);
  });
  return Adapter(shared_, best->first, std::move(best->second));
}

// ---- device -------------------------------------------------------------------------

Result<Device> Adapter::request_device(const DeviceDescriptor& desc) const {
  std::uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, families.data());
  std::optional<std::uint32_t> family;
  for (std::uint32_t i = 0; i < family_count; ++i) {
    const auto need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if ((families[i].queueFlags & need) == need) {
      family = i;
      break;
    }
  }
  if (!family) return fail(ErrorKind::Unsupported, "adapter '{}' has no graphics+compute queue", info_.name);

  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &f13};
  VkPhysicalDeviceFeatures2 supported{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f12};
  vkGetPhysicalDeviceFeatures2(physical_, &supported);
  if (!f13.dynamicRendering || !f13.synchronization2)
    return fail(ErrorKind::Unsupported, "adapter '{}' lacks dynamicRendering or synchronization2", info_.name);

  VkPhysicalDeviceVulkan13Features e13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  e13.dynamicRendering = VK_TRUE;
  e13.synchronization2 = VK_TRUE;
  e13.maintenance4 = f13.maintenance4;
  VkPhysicalDeviceVulkan12Features e12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &e13};
  e12.hostQueryReset = f12.hostQueryReset;
  e12.scalarBlockLayout = f12.scalarBlockLayout;
  VkPhysicalDeviceFeatures2 enabled{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &e12};
  enabled.features.samplerAnisotropy = supported.features.samplerAnisotropy;
  enabled.features.sampleRateShading = supported.features.sampleRateShading;
  enabled.features.fillModeNonSolid = supported.features.fillModeNonSolid;
  enabled.features.shaderStorageImageWriteWithoutFormat = supported.features.shaderStorageImageWriteWithoutFormat;
  enabled.features.shaderStorageImageReadWithoutFormat = supported.features.shaderStorageImageReadWithoutFormat;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queue_info.queueFamilyIndex = *family;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;

  VkDeviceCreateInfo info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &enabled};
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queue_info;
  // A presenting instance's devices can make swapchains, where the adapter offers them.
  const char* swapchain_extension = "VK_KHR_swapchain";
  bool swapchain = false;
  if (shared_->presentation) {
    std::uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical_, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> exts(count);
    vkEnumerateDeviceExtensionProperties(physical_, nullptr, &count, exts.data());
    swapchain = std::any_of(exts.begin(), exts.end(),
                            [&](auto& e) { return std::strcmp(e.extensionName, swapchain_extension) == 0; });
  }
  if (swapchain) {
    info.enabledExtensionCount = 1;
    info.ppEnabledExtensionNames = &swapchain_extension;
  }

  auto shared = std::make_shared<DeviceShared>();
  shared->instance = shared_;
  shared->physical = physical_;
  shared->info = info_;
  shared->queue_family = *family;
  shared->swapchain = swapchain;
  if (VkResult r = vkCreateDevice(physical_, &info, nullptr, &shared->device); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("vkCreateDevice on '{}'", info_.name)));
  vkGetDeviceQueue(shared->device, *family, 0, &shared->queue);
  vkGetPhysicalDeviceMemoryProperties(physical_, &shared->memory_properties);
  shared->info.limits.timestamps = shared->info.limits.timestamps && families[*family].timestampValidBits > 0;

  shared->set_name(VK_OBJECT_TYPE_DEVICE, std::uint64_t(shared->device), desc.label);

  Device device;
  device.shared_ = shared;
  device.queue_.device_ = shared;
  return device;
}

Device Device::create_declaring(std::string label) {
  auto shared = std::make_shared<DeviceShared>();
  shared->info.name = label + " (no adapter: declares, never executes)";
  shared->info.driver = "none";
  shared->info.type = AdapterType::Other;
  // A desktop adapter's limits (lavapipe's and most GPUs' texture size; Vulkan's guaranteed
  // minimums for the rest), where weft reads a limit to choose a size: a shadow map's
  // resolution is capped by max_texture_dimension_2d.
  shared->info.limits.max_texture_dimension_2d = 16384;
  shared->info.limits.max_push_constant_size = 128;
  shared->info.limits.max_bound_descriptor_sets = 4;
  shared->info.limits.max_compute_workgroup_size = {128, 128, 64};
  shared->info.limits.max_compute_invocations = 128;
  shared->info.limits.max_storage_buffer_range = std::uint64_t(1) << 27;
  shared->info.limits.min_uniform_buffer_offset_alignment = 256;
  shared->info.limits.min_storage_buffer_offset_alignment = 256;
  shared->info.limits.max_compute_shared_memory = 16384;
  // Vulkan guarantees 1 and 4 samples for colour and depth attachments and sampled images,
  // and the sample-zero depth resolve; anisotropy is optional (1: off).
  shared->info.limits.color_sample_counts = shared->info.limits.depth_sample_counts = 1 | 4;
  shared->info.limits.sampled_color_sample_counts = shared->info.limits.sampled_depth_sample_counts = 1 | 4;
  shared->info.limits.depth_resolve_modes = 1;
  shared->info.limits.max_sampler_anisotropy = 1.0f;
  Device device;
  device.shared_ = shared;
  device.queue_.device_ = shared;
  return device;
}

bool Device::declaring() const { return shared_ && shared_->declaring(); }

Device::Device(Device&&) noexcept = default;
Device& Device::operator=(Device&&) noexcept = default;
Device::~Device() {
  if (shared_ && !shared_->declaring()) (void)shared_->wait_idle();
}

const AdapterInfo& Device::adapter_info() const { return shared_->info; }
std::uint64_t Device::allocated_bytes() const { return shared_->allocated_bytes; }

}  // namespace weft::gpu

namespace weft::gpu::detail {

DeviceShared::~DeviceShared() {
  if (!device) return;
  vkDeviceWaitIdle(device);
  for (auto& p : pending) {
    vkDestroyFence(device, p.fence, nullptr);
    vkFreeCommandBuffers(device, p.pool, 1, &p.cmd);
  }
  for (auto& [thread, pool] : pools) vkDestroyCommandPool(device, pool, nullptr);
  vkDestroyDevice(device, nullptr);
}

void DeviceShared::set_name(VkObjectType type, std::uint64_t handle, std::string_view name) const {
  if (!instance || !instance->debug_utils || name.empty() || !handle) return;
  auto fn = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
      vkGetInstanceProcAddr(instance->instance, "vkSetDebugUtilsObjectNameEXT"));
  if (!fn) return;
  std::string n(name);
  VkDebugUtilsObjectNameInfoEXT name_info{VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  name_info.objectType = type;
  name_info.objectHandle = handle;
  name_info.pObjectName = n.c_str();
  fn(device, &name_info);
}

Result<VkCommandPool> DeviceShared::thread_pool() {
  std::lock_guard lock(mutex);
  auto& pool = pools[std::this_thread::get_id()];
  if (!pool) {
    VkCommandPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    pool_info.queueFamilyIndex = queue_family;
    if (VkResult r = vkCreateCommandPool(device, &pool_info, nullptr, &pool); r != VK_SUCCESS) {
      pool = VK_NULL_HANDLE;
      return std::unexpected(vk_error(r, "vkCreateCommandPool"));
    }
  }
  return pool;
}

Result<void> DeviceShared::submit(VkCommandPool pool, VkCommandBuffer cmd, VkSemaphore signal, std::string_view label) {
  VkFenceCreateInfo fence_info{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence = VK_NULL_HANDLE;
  if (VkResult r = vkCreateFence(device, &fence_info, nullptr, &fence); r != VK_SUCCESS) {
    vkFreeCommandBuffers(device, pool, 1, &cmd);
    return std::unexpected(vk_error(r, "creating a fence"));
  }
  VkCommandBufferSubmitInfo buffer{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  buffer.commandBuffer = cmd;
  VkSemaphoreSubmitInfo signal_info{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  signal_info.semaphore = signal;
  signal_info.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkSubmitInfo2 submit{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  submit.commandBufferInfoCount = 1;
  submit.pCommandBufferInfos = &buffer;
  submit.signalSemaphoreInfoCount = signal ? 1 : 0;
  submit.pSignalSemaphoreInfos = signal ? &signal_info : nullptr;
  std::lock_guard lock(mutex);
  if (VkResult r = vkQueueSubmit2(queue, 1, &submit, fence); r != VK_SUCCESS) {
    vkDestroyFence(device, fence, nullptr);
    vkFreeCommandBuffers(device, pool, 1, &cmd);
    return std::unexpected(vk_error(r, weft::format("submitting '{}'", label)));
  }
  pending.push_back({fence, pool, cmd, std::this_thread::get_id()});
  return {};
}

// Only this thread's submissions are waited for (the queue runs in order, so that covers
// everything submitted before them): the viewer's window thread must not wait for the
// render thread's frame on a shared device.
Result<void> DeviceShared::wait_idle() {
  std::vector<Pending> mine;
  {
    std::lock_guard lock(mutex);
    const auto self = std::this_thread::get_id();
    // This thread's submissions out, the others' kept in order (std::stable_partition would
    // do, but libstdc++ 12's uses the deprecated get_temporary_buffer).
    std::vector<Pending> others;
    for (const Pending& p : pending) (p.thread == self ? mine : others).push_back(p);
    pending = std::move(others);
  }
  if (mine.empty()) return {};
  std::vector<VkFence> fences;
  for (auto& p : mine) fences.push_back(p.fence);
  const VkResult r = vkWaitForFences(device, std::uint32_t(fences.size()), fences.data(), VK_TRUE, UINT64_MAX);
  for (auto& p : mine) {
    vkDestroyFence(device, p.fence, nullptr);
    vkFreeCommandBuffers(device, p.pool, 1, &p.cmd);  // this thread's pool: no other thread uses it
  }
  if (r != VK_SUCCESS) return std::unexpected(vk_error(r, "waiting for the queue"));
  return {};
}

}  // namespace weft::gpu::detail
