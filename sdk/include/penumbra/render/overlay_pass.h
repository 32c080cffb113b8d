// A render pass that draws over a frame the Renderer recorded: a UI (Dear ImGui's backend records
// into it), a HUD, debug overlays. Used by the editor and the sample games.
//
// The target's colour is loaded, not cleared: record the Renderer's frame with
// RenderTarget::final_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, then begin() this pass on
// the same target; the image leaves it in the pass's `final_layout` (PRESENT_SRC_KHR for a
// swapchain image, TRANSFER_SRC_OPTIMAL to copy it out). A framebuffer per image view is made on
// first use and all are remade when the target's size changes; when a swapchain is
// recreated at the same size, release_framebuffers(). Not thread-safe.
#pragma once

#include <memory>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/render/device.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

class OverlayPass {
 public:
  // Errors: Internal naming the Vulkan call that failed.
  static Result<std::unique_ptr<OverlayPass>> create(Device& device, VkFormat format, VkImageLayout final_layout);
  ~OverlayPass();
  OverlayPass(const OverlayPass&) = delete;
  OverlayPass& operator=(const OverlayPass&) = delete;

  // The render pass (one subpass, one colour attachment), e.g. for ImGui_ImplVulkan_Init.
  VkRenderPass render_pass() const;
  // Begins the pass over all of `target` in `cmd` (inline contents). Errors: a framebuffer that
  // cannot be made (Internal). end() closes it.
  Status begin(VkCommandBuffer cmd, const RenderTarget& target);
  void end(VkCommandBuffer cmd);
  // Destroys the framebuffers (waits for the device to be idle), for image views about to go away.
  void release_framebuffers();

 private:
  struct Impl;
  explicit OverlayPass(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
