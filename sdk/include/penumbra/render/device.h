// The Vulkan device every renderer, window and editor in Penumbra shares.
//
// Vulkan 1.2 or later. Picks a discrete GPU, then an integrated one, then a CPU implementation
// (Mesa lavapipe on machines without a GPU); the loader's VK_DRIVER_FILES / VK_ICD_FILENAMES are
// respected because the loader applies them before we enumerate. With `validation` on, the Khronos
// validation layer is enabled and every message it reports is counted and sent to the log, so a
// test can fail on any message.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"

namespace penumbra {

struct DeviceOptions {
  bool validation = false;  // VK_LAYER_KHRONOS_validation + a debug messenger
  // Extra instance extensions, e.g. glfwGetRequiredInstanceExtensions() for a window surface.
  std::vector<std::string> instance_extensions;
  // Request VK_KHR_swapchain on the device (needed by Swapchain).
  bool swapchain = false;
};

class Device {
 public:
  // Errors: no Vulkan loader or driver, no device with Vulkan 1.2 and a graphics queue, the
  // validation layer requested but not installed (names the Debian package), a missing extension.
  static Result<std::unique_ptr<Device>> create(const DeviceOptions& options);
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  VkInstance instance() const;
  VkPhysicalDevice physical_device() const;
  VkDevice device() const;
  VkQueue queue() const;               // one graphics + compute + transfer queue
  std::uint32_t queue_family() const;
  const std::string& name() const;     // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  bool is_software() const;            // VK_PHYSICAL_DEVICE_TYPE_CPU

  // Validation messages (warnings and errors) reported since creation; thread-safe.
  std::uint32_t validation_messages() const;
  std::string last_validation_message() const;

  // Runs `record` in a one-time command buffer, submits it and waits. For uploads and readbacks.
  Status submit_and_wait(const std::function<void(VkCommandBuffer)>& record);

 private:
  struct Impl;
  explicit Device(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
