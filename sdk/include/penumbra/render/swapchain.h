// A swapchain for a window surface (the editor and the samples), on the shared Device.
#pragma once

#include <cstdint>
#include <memory>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/render/device.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

struct SwapchainOptions {
  VkPresentModeKHR present_mode = VK_PRESENT_MODE_FIFO_KHR;
};

class Swapchain {
 public:
  // `surface` is created by the caller (glfwCreateWindowSurface); the Swapchain takes ownership.
  static Result<std::unique_ptr<Swapchain>> create(Device& device, VkSurfaceKHR surface,
                                                   std::uint32_t width, std::uint32_t height,
                                                   const SwapchainOptions& options = {});
  ~Swapchain();
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // Acquires the next image; the RenderTarget wraps it (final_layout = PRESENT_SRC unless the
  // caller changes it). Returns an OutOfDate-style error when the window was resized: call resize().
  Result<RenderTarget> acquire();
  // Submits `cmd` (waiting for the acquire, signalling for present) and presents the image.
  Status present(VkCommandBuffer cmd);
  Status resize(std::uint32_t width, std::uint32_t height);
  VkFormat format() const;
  VkExtent2D extent() const;
  std::uint32_t image_count() const;

 private:
  struct Impl;
  explicit Swapchain(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
