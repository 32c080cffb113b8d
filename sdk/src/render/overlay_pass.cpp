// The load-and-draw-over pass (overlay_pass.h).
#include "penumbra/render/overlay_pass.h"

#include <string>
#include <unordered_map>

#include "penumbra/render/vk_util.h"

namespace penumbra {

namespace {

Error vk_error(const char* what, VkResult r) {
  return make_error(ErrorCode::Internal, std::string("overlay pass: ") + what + " failed (" + vk::vk_result_name(r) + ")");
}

}  // namespace

struct OverlayPass::Impl {
  VkDevice vk = VK_NULL_HANDLE;
  VkRenderPass pass = VK_NULL_HANDLE;
  std::unordered_map<VkImageView, VkFramebuffer> framebuffers;
  VkExtent2D extent{0, 0};

  void destroy_framebuffers() {
    for (auto& [view, fb] : framebuffers) vkDestroyFramebuffer(vk, fb, nullptr);
    framebuffers.clear();
  }
  ~Impl() {
    if (!vk) return;
    vkDeviceWaitIdle(vk);
    destroy_framebuffers();
    if (pass) vkDestroyRenderPass(vk, pass, nullptr);
  }
};

OverlayPass::OverlayPass(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OverlayPass::~OverlayPass() = default;

Result<std::unique_ptr<OverlayPass>> OverlayPass::create(Device& device, VkFormat format, VkImageLayout final_layout) {
  auto impl = std::make_unique<Impl>();
  impl->vk = device.device();
  VkAttachmentDescription color{};
  color.format = format;
  color.samples = VK_SAMPLE_COUNT_1_BIT;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;  // the renderer's frame stays underneath
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  color.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.finalLayout = final_layout;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &ref;
  // The renderer's colour writes happen before the overlay blends over them; a read-back copy
  // (TRANSFER_SRC) waits for the overlay's.
  VkSubpassDependency in{};
  in.srcSubpass = VK_SUBPASS_EXTERNAL;
  in.dstSubpass = 0;
  in.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  in.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  in.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  in.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  VkSubpassDependency out{};
  out.srcSubpass = 0;
  out.dstSubpass = VK_SUBPASS_EXTERNAL;
  out.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  out.dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
  out.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  out.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  const VkSubpassDependency deps[] = {in, out};
  auto info = vk::vk_struct<VkRenderPassCreateInfo>(VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO);
  info.attachmentCount = 1;
  info.pAttachments = &color;
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = 2;
  info.pDependencies = deps;
  if (VkResult r = vkCreateRenderPass(impl->vk, &info, nullptr, &impl->pass); r != VK_SUCCESS)
    return vk_error("vkCreateRenderPass", r);
  return std::unique_ptr<OverlayPass>(new OverlayPass(std::move(impl)));
}

VkRenderPass OverlayPass::render_pass() const { return impl_->pass; }

Status OverlayPass::begin(VkCommandBuffer cmd, const RenderTarget& target) {
  Impl& m = *impl_;
  if (m.extent.width != target.width || m.extent.height != target.height) {
    if (!m.framebuffers.empty()) vkDeviceWaitIdle(m.vk);
    m.destroy_framebuffers();
    m.extent = {target.width, target.height};
  }
  VkFramebuffer fb = VK_NULL_HANDLE;
  if (auto it = m.framebuffers.find(target.view); it != m.framebuffers.end()) {
    fb = it->second;
  } else {
    auto info = vk::vk_struct<VkFramebufferCreateInfo>(VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO);
    info.renderPass = m.pass;
    info.attachmentCount = 1;
    info.pAttachments = &target.view;
    info.width = target.width;
    info.height = target.height;
    info.layers = 1;
    if (VkResult r = vkCreateFramebuffer(m.vk, &info, nullptr, &fb); r != VK_SUCCESS)
      return vk_error("vkCreateFramebuffer", r);
    m.framebuffers.emplace(target.view, fb);
  }
  auto rp = vk::vk_struct<VkRenderPassBeginInfo>(VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO);
  rp.renderPass = m.pass;
  rp.framebuffer = fb;
  rp.renderArea.extent = {target.width, target.height};
  vkCmdBeginRenderPass(cmd, &rp, VK_SUBPASS_CONTENTS_INLINE);
  return {};
}

void OverlayPass::end(VkCommandBuffer cmd) { vkCmdEndRenderPass(cmd); }

void OverlayPass::release_framebuffers() {
  if (!impl_->framebuffers.empty()) vkDeviceWaitIdle(impl_->vk);
  impl_->destroy_framebuffers();
}

}  // namespace penumbra
