// A window-surface swapchain on the shared Device: acquire, submit + present, resize.
#include "penumbra/render/swapchain.h"

#include <algorithm>
#include <vector>

#include "penumbra/render/vk_util.h"

namespace penumbra {

struct Swapchain::Impl {
  Device* device = nullptr;
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  SwapchainOptions options;
  VkSwapchainKHR swapchain = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkExtent2D extent{};
  std::vector<VkImage> images;
  std::vector<VkImageView> views;
  std::vector<VkSemaphore> rendered;  // per image: the submission finished, present may start
  VkSemaphore acquired = VK_NULL_HANDLE;
  VkFence frame_fence = VK_NULL_HANDLE;
  std::uint32_t current = 0;
  bool out_of_date = false;

  void destroy_chain() {
    VkDevice d = device->device();
    for (VkImageView v : views) vkDestroyImageView(d, v, nullptr);
    for (VkSemaphore s : rendered) vkDestroySemaphore(d, s, nullptr);
    views.clear();
    rendered.clear();
    images.clear();
  }
  ~Impl() {
    if (!device) return;
    VkDevice d = device->device();
    vkDeviceWaitIdle(d);
    destroy_chain();
    if (swapchain) vkDestroySwapchainKHR(d, swapchain, nullptr);
    if (acquired) vkDestroySemaphore(d, acquired, nullptr);
    if (frame_fence) vkDestroyFence(d, frame_fence, nullptr);
    if (surface) vkDestroySurfaceKHR(device->instance(), surface, nullptr);
  }

  Status build(std::uint32_t width, std::uint32_t height) {
    VkPhysicalDevice pd = device->physical_device();
    VkDevice d = device->device();
    VkBool32 supported = VK_FALSE;
    vkGetPhysicalDeviceSurfaceSupportKHR(pd, device->queue_family(), surface, &supported);
    if (!supported) {
      return make_error(ErrorCode::Unsupported, "Swapchain: the device's queue cannot present to this surface");
    }
    VkSurfaceCapabilitiesKHR caps;
    vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface, &caps);
    std::uint32_t count = 0;
    vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &count, nullptr);
    std::vector<VkSurfaceFormatKHR> formats(count);
    vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &count, formats.data());
    if (formats.empty()) return make_error(ErrorCode::Unsupported, "Swapchain: the surface reports no formats");
    // Prefer an sRGB format (the hardware encodes); UNORM works too (the shader encodes).
    VkSurfaceFormatKHR chosen = formats[0];
    for (const VkSurfaceFormatKHR& f : formats) {
      if (f.format == VK_FORMAT_B8G8R8A8_SRGB || f.format == VK_FORMAT_R8G8B8A8_SRGB) chosen = f;
    }
    vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &count, nullptr);
    std::vector<VkPresentModeKHR> modes(count);
    vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &count, modes.data());
    const bool has_mode = std::find(modes.begin(), modes.end(), options.present_mode) != modes.end();
    extent = caps.currentExtent;
    if (extent.width == 0xFFFFFFFFu) {
      extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
      extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
    }
    std::uint32_t image_count = caps.minImageCount + 1;
    if (caps.maxImageCount > 0) image_count = std::min(image_count, caps.maxImageCount);

    auto info = vk::vk_struct<VkSwapchainCreateInfoKHR>(VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR);
    info.surface = surface;
    info.minImageCount = image_count;
    info.imageFormat = chosen.format;
    info.imageColorSpace = chosen.colorSpace;
    info.imageExtent = extent;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                      VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    info.presentMode = has_mode ? options.present_mode : VK_PRESENT_MODE_FIFO_KHR;
    info.clipped = VK_TRUE;
    info.oldSwapchain = swapchain;
    VkSwapchainKHR next = VK_NULL_HANDLE;
    if (VkResult r = vkCreateSwapchainKHR(d, &info, nullptr, &next); r != VK_SUCCESS) {
      return make_error(ErrorCode::Unsupported, std::string("Swapchain: vkCreateSwapchainKHR failed (") +
                                                    vk_result_name(r) + ")");
    }
    destroy_chain();
    if (swapchain) vkDestroySwapchainKHR(d, swapchain, nullptr);
    swapchain = next;
    format = chosen.format;
    vkGetSwapchainImagesKHR(d, swapchain, &count, nullptr);
    images.resize(count);
    vkGetSwapchainImagesKHR(d, swapchain, &count, images.data());
    for (VkImage image : images) {
      auto view = vk::vk_struct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
      view.image = image;
      view.viewType = VK_IMAGE_VIEW_TYPE_2D;
      view.format = format;
      view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      VkImageView v = VK_NULL_HANDLE;
      auto sem = vk::vk_struct<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
      VkSemaphore s = VK_NULL_HANDLE;
      if (vkCreateImageView(d, &view, nullptr, &v) != VK_SUCCESS ||
          vkCreateSemaphore(d, &sem, nullptr, &s) != VK_SUCCESS) {
        return make_error(ErrorCode::Internal, "Swapchain: cannot create image views or semaphores");
      }
      views.push_back(v);
      rendered.push_back(s);
    }
    out_of_date = false;
    return {};
  }
};

Result<std::unique_ptr<Swapchain>> Swapchain::create(Device& device, VkSurfaceKHR surface, std::uint32_t width,
                                                     std::uint32_t height, const SwapchainOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->device = &device;
  impl->surface = surface;
  impl->options = options;
  auto sem = vk::vk_struct<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
  auto fence = vk::vk_struct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  fence.flags = VK_FENCE_CREATE_SIGNALED_BIT;
  if (vkCreateSemaphore(device.device(), &sem, nullptr, &impl->acquired) != VK_SUCCESS ||
      vkCreateFence(device.device(), &fence, nullptr, &impl->frame_fence) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Swapchain: cannot create synchronisation objects");
  }
  PENUMBRA_TRY(impl->build(width, height));
  return std::unique_ptr<Swapchain>(new Swapchain(std::move(impl)));
}

Swapchain::Swapchain(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Swapchain::~Swapchain() = default;

Result<RenderTarget> Swapchain::acquire() {
  VkDevice d = impl_->device->device();
  // One frame in flight: the previous submission must be done before its semaphore is reused.
  vkWaitForFences(d, 1, &impl_->frame_fence, VK_TRUE, UINT64_MAX);
  const VkResult r = vkAcquireNextImageKHR(d, impl_->swapchain, UINT64_MAX, impl_->acquired, VK_NULL_HANDLE,
                                           &impl_->current);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    impl_->out_of_date = true;
    return make_error(ErrorCode::InvalidInput, "Swapchain: out of date (the window was resized); call resize()");
  }
  if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) {
    return make_error(ErrorCode::Internal, std::string("Swapchain: vkAcquireNextImageKHR failed (") +
                                               vk_result_name(r) + ")");
  }
  RenderTarget t;
  t.image = impl_->images[impl_->current];
  t.view = impl_->views[impl_->current];
  t.format = impl_->format;
  t.width = impl_->extent.width;
  t.height = impl_->extent.height;
  t.layout = VK_IMAGE_LAYOUT_UNDEFINED;
  t.final_layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  return t;
}

Status Swapchain::present(VkCommandBuffer cmd) {
  VkDevice d = impl_->device->device();
  vkResetFences(d, 1, &impl_->frame_fence);
  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  auto submit = vk::vk_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
  submit.waitSemaphoreCount = 1;
  submit.pWaitSemaphores = &impl_->acquired;
  submit.pWaitDstStageMask = &wait_stage;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  submit.signalSemaphoreCount = 1;
  submit.pSignalSemaphores = &impl_->rendered[impl_->current];
  if (VkResult r = vkQueueSubmit(impl_->device->queue(), 1, &submit, impl_->frame_fence); r != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, std::string("Swapchain: vkQueueSubmit failed (") + vk_result_name(r) + ")");
  }
  auto present = vk::vk_struct<VkPresentInfoKHR>(VK_STRUCTURE_TYPE_PRESENT_INFO_KHR);
  present.waitSemaphoreCount = 1;
  present.pWaitSemaphores = &impl_->rendered[impl_->current];
  present.swapchainCount = 1;
  present.pSwapchains = &impl_->swapchain;
  present.pImageIndices = &impl_->current;
  const VkResult r = vkQueuePresentKHR(impl_->device->queue(), &present);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
    impl_->out_of_date = true;
    return make_error(ErrorCode::InvalidInput, "Swapchain: out of date (the window was resized); call resize()");
  }
  if (r != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, std::string("Swapchain: vkQueuePresentKHR failed (") + vk_result_name(r) + ")");
  }
  return {};
}

Status Swapchain::resize(std::uint32_t width, std::uint32_t height) {
  vkDeviceWaitIdle(impl_->device->device());
  return impl_->build(width, height);
}

bool Swapchain::out_of_date() const { return impl_->out_of_date; }
VkFormat Swapchain::format() const { return impl_->format; }
VkExtent2D Swapchain::extent() const { return impl_->extent; }
std::uint32_t Swapchain::image_count() const { return static_cast<std::uint32_t>(impl_->images.size()); }

}  // namespace penumbra
