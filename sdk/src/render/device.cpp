// Vulkan instance, device selection, validation messages and one-time submissions.
#include "penumbra/render/device.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>

#include "penumbra/core/log.h"
#include "penumbra/render/vk_util.h"

namespace penumbra {

namespace {
// What the validation messenger reports, counted for tests.
struct MessageCounter {
  std::atomic<std::uint32_t> messages{0};
  std::mutex mutex;
  std::string last;
};
}  // namespace

struct Device::Impl {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  std::string name;
  bool software = false;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  std::mutex submit_mutex;

  MessageCounter validation;

  ~Impl() {
    if (device) {
      vkDeviceWaitIdle(device);
      if (fence) vkDestroyFence(device, fence, nullptr);
      if (pool) vkDestroyCommandPool(device, pool, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (messenger) {
      auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
      if (destroy) destroy(instance, messenger, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
  }
};

namespace {

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                     void* user) {
  auto* counter = static_cast<MessageCounter*>(user);
  const std::string text = data && data->pMessage ? data->pMessage : "(no message)";
  counter->messages.fetch_add(1);
  {
    std::lock_guard lock(counter->mutex);
    counter->last = text;
  }
  const bool error = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) != 0;
  log(error ? LogLevel::Error : LogLevel::Warning, "vulkan validation: " + text);
  return VK_FALSE;
}

bool has_layer(const char* name) {
  std::uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

// Discrete GPU first, then integrated, virtual, CPU (lavapipe), other.
int type_rank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

}  // namespace

Result<std::unique_ptr<Device>> Device::create(const DeviceOptions& options) {
  auto impl = std::make_unique<Impl>();
  constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

  // Instance, with the validation layer and a messenger that counts what it reports.
  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  for (const std::string& e : options.instance_extensions) extensions.push_back(e.c_str());
  if (options.validation) {
    if (!has_layer(kValidationLayer)) {
      return make_error(ErrorCode::NotFound,
                        "Vulkan: the validation layer VK_LAYER_KHRONOS_validation is not installed; install "
                        "the Debian package vulkan-validationlayers or create the Device without validation");
    }
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  auto app = vk::vk_struct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "penumbra";
  app.pEngineName = "penumbra";
  app.apiVersion = VK_API_VERSION_1_3;
  auto messenger_info = vk::vk_struct<VkDebugUtilsMessengerCreateInfoEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
  messenger_info.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = on_validation_message;
  messenger_info.pUserData = &impl->validation;
  auto instance_info = vk::vk_struct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  instance_info.pApplicationInfo = &app;
  instance_info.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  instance_info.ppEnabledLayerNames = layers.data();
  instance_info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  instance_info.ppEnabledExtensionNames = extensions.data();
  if (options.validation) instance_info.pNext = &messenger_info;  // also covers instance creation
  if (VkResult r = vkCreateInstance(&instance_info, nullptr, &impl->instance); r != VK_SUCCESS) {
    return make_error(ErrorCode::Unsupported,
                      "Vulkan: vkCreateInstance failed (" + std::string(vk_result_name(r)) +
                          "); install a Vulkan driver (Debian: mesa-vulkan-drivers for lavapipe) or check "
                          "VK_DRIVER_FILES and the requested instance extensions");
  }
  if (options.validation) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(impl->instance, "vkCreateDebugUtilsMessengerEXT"));
    if (!create || create(impl->instance, &messenger_info, nullptr, &impl->messenger) != VK_SUCCESS) {
      return make_error(ErrorCode::Unsupported, "Vulkan: cannot create the validation messenger (VK_EXT_debug_utils)");
    }
  }

  // Physical device: Vulkan 1.3 (dynamic rendering, synchronization2) with a graphics queue.
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(impl->instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(impl->instance, &count, devices.data());
  int best_rank = 1 << 30;
  for (VkPhysicalDevice pd : devices) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(pd, &props);
    if (props.apiVersion < VK_API_VERSION_1_3) continue;
    std::uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &families, nullptr);
    std::vector<VkQueueFamilyProperties> family_props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &families, family_props.data());
    for (std::uint32_t f = 0; f < families; ++f) {
      const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if ((family_props[f].queueFlags & need) != need) continue;
      const int rank = type_rank(props.deviceType);
      if (rank < best_rank) {
        best_rank = rank;
        impl->physical = pd;
        impl->family = f;
        impl->name = props.deviceName;
        impl->software = props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
      }
      break;
    }
  }
  if (!impl->physical) {
    return make_error(ErrorCode::Unsupported,
                      "Vulkan: no device with Vulkan 1.3 and a graphics queue (found " + std::to_string(count) +
                          " devices); install mesa-vulkan-drivers for the lavapipe CPU driver");
  }

  // Logical device with the features the renderer records with.
  auto features13 = vk::vk_struct<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  auto supported = vk::vk_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  supported.pNext = &features13;
  vkGetPhysicalDeviceFeatures2(impl->physical, &supported);
  if (!features13.dynamicRendering || !features13.synchronization2 || !supported.features.depthClamp ||
      !supported.features.independentBlend) {
    return make_error(ErrorCode::Unsupported, "Vulkan: " + impl->name +
                                                  " lacks dynamic rendering, synchronization2, depth clamp or "
                                                  "independent blend; update the driver");
  }
  auto enable13 = vk::vk_struct<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  enable13.dynamicRendering = VK_TRUE;
  enable13.synchronization2 = VK_TRUE;
  auto enable = vk::vk_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  enable.pNext = &enable13;
  enable.features.depthClamp = VK_TRUE;        // render features' volumes reach past the far plane
  enable.features.independentBlend = VK_TRUE;  // features blend the ambient image, not its key
  std::vector<const char*> device_extensions;
  if (options.swapchain) device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  const float priority = 1.0f;
  auto queue_info = vk::vk_struct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  queue_info.queueFamilyIndex = impl->family;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  auto device_info = vk::vk_struct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  device_info.pNext = &enable;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  device_info.enabledExtensionCount = static_cast<std::uint32_t>(device_extensions.size());
  device_info.ppEnabledExtensionNames = device_extensions.data();
  if (VkResult r = vkCreateDevice(impl->physical, &device_info, nullptr, &impl->device); r != VK_SUCCESS) {
    return make_error(ErrorCode::Unsupported, "Vulkan: vkCreateDevice on " + impl->name + " failed (" +
                                                  vk_result_name(r) + ")" +
                                                  (options.swapchain ? "; does it support VK_KHR_swapchain?" : ""));
  }
  vkGetDeviceQueue(impl->device, impl->family, 0, &impl->queue);

  auto pool_info = vk::vk_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = impl->family;
  auto fence_info = vk::vk_struct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  if (vkCreateCommandPool(impl->device, &pool_info, nullptr, &impl->pool) != VK_SUCCESS ||
      vkCreateFence(impl->device, &fence_info, nullptr, &impl->fence) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Vulkan: cannot create the upload command pool");
  }
  return std::unique_ptr<Device>(new Device(std::move(impl)));
}

Device::Device(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Device::~Device() = default;

VkInstance Device::instance() const { return impl_->instance; }
VkPhysicalDevice Device::physical_device() const { return impl_->physical; }
VkDevice Device::device() const { return impl_->device; }
VkQueue Device::queue() const { return impl_->queue; }
std::uint32_t Device::queue_family() const { return impl_->family; }
const std::string& Device::name() const { return impl_->name; }
bool Device::is_software() const { return impl_->software; }
std::uint32_t Device::validation_messages() const { return impl_->validation.messages.load(); }
std::string Device::last_validation_message() const {
  std::lock_guard lock(impl_->validation.mutex);
  return impl_->validation.last;
}

Status Device::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) {
  std::lock_guard lock(impl_->submit_mutex);
  auto alloc = vk::vk_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  alloc.commandPool = impl_->pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (vkAllocateCommandBuffers(impl_->device, &alloc, &cmd) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Vulkan: cannot allocate a command buffer");
  }
  auto begin = vk::vk_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(cmd, &begin);
  record(cmd);
  vkEndCommandBuffer(cmd);
  auto submit = vk::vk_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  VkResult r = vkQueueSubmit(impl_->queue, 1, &submit, impl_->fence);
  if (r == VK_SUCCESS) r = vkWaitForFences(impl_->device, 1, &impl_->fence, VK_TRUE, UINT64_MAX);
  vkResetFences(impl_->device, 1, &impl_->fence);
  vkFreeCommandBuffers(impl_->device, impl_->pool, 1, &cmd);
  if (r != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, std::string("Vulkan: submission failed (") + vk_result_name(r) + ")");
  }
  return {};
}

}  // namespace penumbra
