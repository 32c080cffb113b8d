// Window output: renderer + ImGui render pass + swapchain + read-back (viewport.h).
#include "viewport.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <vector>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_vulkan.h>
#include <imgui.h>

#include "penumbra/render/overlay_pass.h"

namespace penumbra::editor {

namespace {

Error vk_error(const char* what, VkResult r) {
  return make_error(ErrorCode::Internal, std::string("viewport: ") + what + " failed (VkResult " +
                                             std::to_string(static_cast<int>(r)) + ")");
}

// A zeroed Vulkan info struct with its sType set.
template <class T>
T vk_struct(VkStructureType type) {
  T s{};
  s.sType = type;
  return s;
}

void check_imgui_vk(VkResult) {}  // failures show up as validation messages and in the frame's result

}  // namespace

struct Viewport::Impl {
  GLFWwindow* window = nullptr;
  std::unique_ptr<Device> device;
  std::unique_ptr<Swapchain> swapchain;
  std::unique_ptr<Renderer> renderer;
  VkDevice vk = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkDescriptorPool imgui_pool = VK_NULL_HANDLE;
  // The UI pass loads the renderer's image; one pass ends ready to present, the other ready to copy.
  std::unique_ptr<OverlayPass> ui_pass, ui_pass_capture;
  bool imgui_ready = false;
  // The scaled 3D view: its own colour image, blitted up to the swapchain image.
  float render_scale = 1.0f;
  VkImage scaled = VK_NULL_HANDLE;
  VkDeviceMemory scaled_memory = VK_NULL_HANDLE;
  VkImageView scaled_view = VK_NULL_HANDLE;
  VkExtent2D scaled_extent{0, 0};
  // Read-back buffer (host visible), grown on demand.
  VkBuffer readback = VK_NULL_HANDLE;
  VkDeviceMemory readback_memory = VK_NULL_HANDLE;
  VkDeviceSize readback_size = 0;

  ~Impl() {
    if (vk) vkDeviceWaitIdle(vk);
    if (imgui_ready) ImGui_ImplVulkan_Shutdown();
    ui_pass.reset();
    ui_pass_capture.reset();
    destroy_scaled();
    if (readback) vkDestroyBuffer(vk, readback, nullptr);
    if (readback_memory) vkFreeMemory(vk, readback_memory, nullptr);
    if (imgui_pool) vkDestroyDescriptorPool(vk, imgui_pool, nullptr);
    if (pool) vkDestroyCommandPool(vk, pool, nullptr);
    renderer.reset();
    swapchain.reset();
    device.reset();
  }

  void destroy_scaled() {
    if (scaled_view) vkDestroyImageView(vk, scaled_view, nullptr);
    if (scaled) vkDestroyImage(vk, scaled, nullptr);
    if (scaled_memory) vkFreeMemory(vk, scaled_memory, nullptr);
    scaled_view = VK_NULL_HANDLE;
    scaled = VK_NULL_HANDLE;
    scaled_memory = VK_NULL_HANDLE;
    scaled_extent = {0, 0};
  }

  Result<std::uint32_t> memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags want) {
    VkPhysicalDeviceMemoryProperties props;
    vkGetPhysicalDeviceMemoryProperties(device->physical_device(), &props);
    for (std::uint32_t i = 0; i < props.memoryTypeCount; ++i)
      if ((type_bits & (1u << i)) && (props.memoryTypes[i].propertyFlags & want) == want) return i;
    return make_error(ErrorCode::Unsupported, "viewport: the device has no memory type for the view's images");
  }

  Status ensure_scaled(std::uint32_t width, std::uint32_t height) {
    if (scaled && scaled_extent.width == width && scaled_extent.height == height) return {};
    vkDeviceWaitIdle(vk);
    destroy_scaled();
    auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = swapchain->format();
    info.extent = {width, height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    if (VkResult r = vkCreateImage(vk, &info, nullptr, &scaled); r != VK_SUCCESS) return vk_error("vkCreateImage", r);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(vk, scaled, &req);
    auto type = memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (!type) return type.error();
    auto alloc = vk_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = *type;
    if (VkResult r = vkAllocateMemory(vk, &alloc, nullptr, &scaled_memory); r != VK_SUCCESS)
      return vk_error("vkAllocateMemory", r);
    vkBindImageMemory(vk, scaled, scaled_memory, 0);
    auto view = vk_struct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
    view.image = scaled;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = info.format;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    if (VkResult r = vkCreateImageView(vk, &view, nullptr, &scaled_view); r != VK_SUCCESS)
      return vk_error("vkCreateImageView", r);
    scaled_extent = {width, height};
    return {};
  }

  Status ensure_readback(VkDeviceSize size) {
    if (readback_size >= size) return {};
    if (readback) vkDestroyBuffer(vk, readback, nullptr);
    if (readback_memory) vkFreeMemory(vk, readback_memory, nullptr);
    readback = VK_NULL_HANDLE;
    readback_memory = VK_NULL_HANDLE;
    readback_size = 0;
    auto info = vk_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    info.size = size;
    info.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    if (VkResult r = vkCreateBuffer(vk, &info, nullptr, &readback); r != VK_SUCCESS) return vk_error("vkCreateBuffer", r);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(vk, readback, &req);
    auto type = memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    if (!type) return type.error();
    auto alloc = vk_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = *type;
    if (VkResult r = vkAllocateMemory(vk, &alloc, nullptr, &readback_memory); r != VK_SUCCESS)
      return vk_error("vkAllocateMemory", r);
    vkBindBufferMemory(vk, readback, readback_memory, 0);
    readback_size = size;
    return {};
  }

  Status resize() {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window, &w, &h);
    if (w <= 0 || h <= 0) return {};  // minimised
    ui_pass->release_framebuffers();
    ui_pass_capture->release_framebuffers();
    return swapchain->resize(static_cast<std::uint32_t>(w), static_cast<std::uint32_t>(h));
  }
};

Viewport::Viewport(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  device_ = impl_->device.get();
  renderer_ = impl_->renderer.get();
}
Viewport::~Viewport() = default;

VkExtent2D Viewport::extent() const { return impl_->swapchain->extent(); }
void Viewport::set_render_scale(float scale) { impl_->render_scale = std::clamp(scale, 0.25f, 1.0f); }
float Viewport::render_scale() const { return impl_->render_scale; }

Result<std::unique_ptr<Viewport>> Viewport::create(GLFWwindow* window, const ViewportOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->window = window;
  DeviceOptions device_options;
  device_options.validation = options.validation;
  device_options.swapchain = true;
  std::uint32_t count = 0;
  const char** extensions = glfwGetRequiredInstanceExtensions(&count);
  if (extensions == nullptr)
    return make_error(ErrorCode::Unsupported, "viewport: GLFW found no Vulkan loader for window surfaces; install "
                                              "libvulkan1 and a driver (mesa-vulkan-drivers)");
  for (std::uint32_t i = 0; i < count; ++i) device_options.instance_extensions.emplace_back(extensions[i]);
  auto device = Device::create(device_options);
  if (!device) return device.error();
  impl->device = std::move(*device);
  impl->vk = impl->device->device();

  VkSurfaceKHR surface = VK_NULL_HANDLE;
  if (VkResult r = glfwCreateWindowSurface(impl->device->instance(), window, nullptr, &surface); r != VK_SUCCESS)
    return vk_error("glfwCreateWindowSurface", r);
  int w = 0, h = 0;
  glfwGetFramebufferSize(window, &w, &h);
  SwapchainOptions swap_options;
  swap_options.present_mode = options.present_mode;
  auto swapchain = Swapchain::create(*impl->device, surface, static_cast<std::uint32_t>(std::max(w, 1)),
                                     static_cast<std::uint32_t>(std::max(h, 1)), swap_options);
  if (!swapchain) return swapchain.error();
  impl->swapchain = std::move(*swapchain);
  auto renderer = Renderer::create(*impl->device);
  if (!renderer) return renderer.error();
  impl->renderer = std::move(*renderer);

  // Command buffer for the frames (one in flight).
  auto pool_info = vk_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = impl->device->queue_family();
  if (VkResult r = vkCreateCommandPool(impl->vk, &pool_info, nullptr, &impl->pool); r != VK_SUCCESS)
    return vk_error("vkCreateCommandPool", r);
  auto cmd_info = vk_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  cmd_info.commandPool = impl->pool;
  cmd_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cmd_info.commandBufferCount = 1;
  if (VkResult r = vkAllocateCommandBuffers(impl->vk, &cmd_info, &impl->cmd); r != VK_SUCCESS)
    return vk_error("vkAllocateCommandBuffers", r);

  // ImGui's Vulkan backend: a descriptor pool for its font texture and its render pass.
  const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16}};
  auto dp = vk_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  dp.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  dp.maxSets = 16;
  dp.poolSizeCount = 1;
  dp.pPoolSizes = sizes;
  if (VkResult r = vkCreateDescriptorPool(impl->vk, &dp, nullptr, &impl->imgui_pool); r != VK_SUCCESS)
    return vk_error("vkCreateDescriptorPool", r);
  auto pass = OverlayPass::create(*impl->device, impl->swapchain->format(), VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
  if (!pass) return pass.error();
  impl->ui_pass = std::move(*pass);
  auto capture_pass = OverlayPass::create(*impl->device, impl->swapchain->format(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  if (!capture_pass) return capture_pass.error();
  impl->ui_pass_capture = std::move(*capture_pass);

  ImGui_ImplVulkan_InitInfo init{};
  init.Instance = impl->device->instance();
  init.PhysicalDevice = impl->device->physical_device();
  init.Device = impl->vk;
  init.QueueFamily = impl->device->queue_family();
  init.Queue = impl->device->queue();
  init.DescriptorPool = impl->imgui_pool;
  init.MinImageCount = std::max(2u, impl->swapchain->image_count());
  init.ImageCount = std::max(2u, impl->swapchain->image_count());
  init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  init.CheckVkResultFn = check_imgui_vk;
  if (!ImGui_ImplVulkan_Init(&init, impl->ui_pass->render_pass()))
    return make_error(ErrorCode::Internal, "viewport: ImGui_ImplVulkan_Init failed");
  impl->imgui_ready = true;
  PENUMBRA_TRY(impl->device->submit_and_wait([](VkCommandBuffer c) { ImGui_ImplVulkan_CreateFontsTexture(c); }));
  ImGui_ImplVulkan_DestroyFontUploadObjects();
  return std::unique_ptr<Viewport>(new Viewport(std::move(impl)));
}

Status Viewport::draw(World& world, const CameraView& camera, const RenderSettings& settings, ImDrawData* ui,
                      Image* capture) {
  Impl& m = *impl_;
  using Clock = std::chrono::steady_clock;
  const auto ms_since = [](Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
  };
  if (m.swapchain->out_of_date()) PENUMBRA_TRY(m.resize());
  auto t = Clock::now();
  auto acquired = m.swapchain->acquire();
  times_.wait_ms = ms_since(t);
  t = Clock::now();
  if (!acquired) {
    if (m.swapchain->out_of_date()) return m.resize();
    return acquired.error();
  }
  RenderTarget target = *acquired;
  PENUMBRA_TRY(m.renderer->sync(world));

  vkResetCommandBuffer(m.cmd, 0);
  auto begin = vk_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(m.cmd, &begin);
  if (m.render_scale >= 1.0f) {
    // The scene straight into the swapchain image, left ready for the UI pass to load.
    target.final_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    if (Status s = m.renderer->record(m.cmd, target, camera, settings); !s) {
      vkEndCommandBuffer(m.cmd);
      return s;
    }
  } else {
    // The scene at the reduced size, then a linear blit up to the swapchain image.
    const auto w = std::max(1u, static_cast<std::uint32_t>(static_cast<float>(target.width) * m.render_scale));
    const auto h = std::max(1u, static_cast<std::uint32_t>(static_cast<float>(target.height) * m.render_scale));
    if (Status s = m.ensure_scaled(w, h); !s) {
      vkEndCommandBuffer(m.cmd);
      return s;
    }
    RenderTarget small;
    small.image = m.scaled;
    small.view = m.scaled_view;
    small.format = target.format;
    small.width = w;
    small.height = h;
    small.layout = VK_IMAGE_LAYOUT_UNDEFINED;
    small.final_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    if (Status s = m.renderer->record(m.cmd, small, camera, settings); !s) {
      vkEndCommandBuffer(m.cmd);
      return s;
    }
    auto to_dst = vk_struct<VkImageMemoryBarrier>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER);
    to_dst.srcAccessMask = 0;
    to_dst.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    to_dst.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    to_dst.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    to_dst.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_dst.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_dst.image = target.image;
    to_dst.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(m.cmd, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                         nullptr, 0, nullptr, 1, &to_dst);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = {static_cast<std::int32_t>(w), static_cast<std::int32_t>(h), 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.dstOffsets[1] = {static_cast<std::int32_t>(target.width), static_cast<std::int32_t>(target.height), 1};
    vkCmdBlitImage(m.cmd, m.scaled, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target.image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    auto to_color = to_dst;
    to_color.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    to_color.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    to_color.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    to_color.newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    vkCmdPipelineBarrier(m.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, 0, 0,
                         nullptr, 0, nullptr, 1, &to_color);
  }
  // The UI on top, in its own render pass.
  OverlayPass& pass = capture ? *m.ui_pass_capture : *m.ui_pass;
  if (Status s = pass.begin(m.cmd, target); !s) {
    vkEndCommandBuffer(m.cmd);
    return s;
  }
  if (ui) ImGui_ImplVulkan_RenderDrawData(ui, m.cmd);
  pass.end(m.cmd);

  const VkDeviceSize bytes = VkDeviceSize{target.width} * target.height * 4;
  if (capture) {
    if (Status s = m.ensure_readback(bytes); !s) {
      vkEndCommandBuffer(m.cmd);
      return s;
    }
    // Copy the finished frame out, then hand the image to the presentation engine.
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {target.width, target.height, 1};
    vkCmdCopyImageToBuffer(m.cmd, target.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, m.readback, 1, &region);
    auto to_present = vk_struct<VkImageMemoryBarrier>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER);
    to_present.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    to_present.dstAccessMask = 0;
    to_present.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    to_present.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    to_present.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_present.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_present.image = target.image;
    to_present.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    auto to_host = vk_struct<VkBufferMemoryBarrier>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER);
    to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    to_host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_host.buffer = m.readback;
    to_host.size = bytes;
    vkCmdPipelineBarrier(m.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1, &to_host,
                         1, &to_present);
  }
  if (VkResult r = vkEndCommandBuffer(m.cmd); r != VK_SUCCESS) return vk_error("vkEndCommandBuffer", r);
  times_.record_ms = ms_since(t);
  t = Clock::now();
  const Status presented = m.swapchain->present(m.cmd);
  if (!presented && !m.swapchain->out_of_date()) return presented;

  if (capture) {
    vkQueueWaitIdle(m.device->queue());
    void* mapped = nullptr;
    if (VkResult r = vkMapMemory(m.vk, m.readback_memory, 0, bytes, 0, &mapped); r != VK_SUCCESS)
      return vk_error("vkMapMemory", r);
    capture->width = target.width;
    capture->height = target.height;
    capture->rgba32f.clear();
    capture->rgba8.resize(static_cast<std::size_t>(bytes));
    std::memcpy(capture->rgba8.data(), mapped, capture->rgba8.size());
    vkUnmapMemory(m.vk, m.readback_memory);
    // Swapchain images are BGRA on most surfaces: swizzle to RGBA and make alpha opaque.
    const bool bgra = target.format == VK_FORMAT_B8G8R8A8_SRGB || target.format == VK_FORMAT_B8G8R8A8_UNORM;
    for (std::size_t i = 0; i < capture->rgba8.size(); i += 4) {
      if (bgra) std::swap(capture->rgba8[i], capture->rgba8[i + 2]);
      capture->rgba8[i + 3] = 255;
    }
  }
  times_.present_ms = ms_since(t);
  return {};
}

}  // namespace penumbra::editor
