// A swapchain for a window surface (the editor and the samples), on the shared Device.
//
// One frame in flight: acquire() waits for the previous present()'s submission. An sRGB surface
// format is preferred (the renderer's shader encodes sRGB itself on UNORM targets). Not
// thread-safe. out_of_date() tells a failed acquire/present that needs
// resize() from other errors (InvalidInput with "out of date" in the message).
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
  // Recreates the images for the new window size (waits for the device to be idle).
  Status resize(std::uint32_t width, std::uint32_t height);
  // True after acquire() or present() found the surface out of date (or suboptimal) until resize().
  bool out_of_date() const;
  VkFormat format() const;
  VkExtent2D extent() const;
  std::uint32_t image_count() const;

 private:
  struct Impl;
  explicit Swapchain(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
