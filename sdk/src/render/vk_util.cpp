#include "penumbra/render/vk_util.h"

namespace penumbra::vk {

const char* vk_result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_SUBOPTIMAL_KHR: return "VK_SUBOPTIMAL_KHR";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_SURFACE_LOST_KHR: return "VK_ERROR_SURFACE_LOST_KHR";
    case VK_ERROR_OUT_OF_DATE_KHR: return "VK_ERROR_OUT_OF_DATE_KHR";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    default: return "VkResult error";
  }
}

Allocator::Allocator(VkPhysicalDevice physical, VkDevice device) : device_(device) {
  vkGetPhysicalDeviceMemoryProperties(physical, &memory_);
}

Result<VkDeviceMemory> Allocator::allocate(const VkMemoryRequirements& req, VkMemoryPropertyFlags flags) {
  for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
    if (!(req.memoryTypeBits & (1u << i)) || (memory_.memoryTypes[i].propertyFlags & flags) != flags) continue;
    auto info = vk::vk_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    info.allocationSize = req.size;
    info.memoryTypeIndex = i;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    if (VkResult r = vkAllocateMemory(device_, &info, nullptr, &memory); r != VK_SUCCESS) {
      return make_error(ErrorCode::OutOfBudget, "Vulkan: cannot allocate " + std::to_string(req.size) +
                                                    " bytes of GPU memory (" + vk_result_name(r) +
                                                    "); use a smaller scene, target or shadow map");
    }
    bytes_ += req.size;
    return memory;
  }
  return make_error(ErrorCode::Unsupported, "Vulkan: no memory type with the required properties");
}

Result<Buffer> Allocator::create_buffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host) {
  Buffer b;
  b.size = size;
  auto info = vk::vk_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  info.size = size > 0 ? size : 16;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  if (vkCreateBuffer(device_, &info, nullptr, &b.buffer) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Vulkan: vkCreateBuffer failed");
  }
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device_, b.buffer, &req);
  auto memory = allocate(req, host ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
                                   : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (!memory) {
    vkDestroyBuffer(device_, b.buffer, nullptr);
    return memory.error();
  }
  b.memory = *memory;
  b.bytes = req.size;
  vkBindBufferMemory(device_, b.buffer, b.memory, 0);
  if (host) vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped);
  return b;
}

Result<ImageResource> Allocator::create_image(const VkImageCreateInfo& info, VkImageViewType view_type,
                                              VkImageAspectFlags aspect) {
  ImageResource img;
  if (vkCreateImage(device_, &info, nullptr, &img.image) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Vulkan: vkCreateImage failed");
  }
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device_, img.image, &req);
  auto memory = allocate(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (!memory) {
    vkDestroyImage(device_, img.image, nullptr);
    return memory.error();
  }
  img.memory = *memory;
  img.bytes = req.size;
  vkBindImageMemory(device_, img.image, img.memory, 0);
  auto view = vk::vk_struct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  view.image = img.image;
  view.viewType = view_type;
  view.format = info.format;
  view.subresourceRange = {aspect, 0, info.mipLevels, 0, info.arrayLayers};
  if (vkCreateImageView(device_, &view, nullptr, &img.view) != VK_SUCCESS) {
    destroy(img);
    return make_error(ErrorCode::Internal, "Vulkan: vkCreateImageView failed");
  }
  return img;
}

void Allocator::destroy(Buffer& b) {
  if (b.buffer) vkDestroyBuffer(device_, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(device_, b.memory, nullptr);
  if (bytes_ >= b.bytes) bytes_ -= b.bytes;
  b = Buffer{};
}

void Allocator::destroy(ImageResource& img) {
  if (img.view) vkDestroyImageView(device_, img.view, nullptr);
  if (img.image) vkDestroyImage(device_, img.image, nullptr);
  if (img.memory) vkFreeMemory(device_, img.memory, nullptr);
  if (bytes_ >= img.bytes) bytes_ -= img.bytes;
  img = ImageResource{};
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from,
                   VkImageLayout to, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  auto b = vk::vk_struct<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, VK_REMAINING_MIP_LEVELS, 0, VK_REMAINING_ARRAY_LAYERS};
  auto dep = vk::vk_struct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

}  // namespace penumbra::vk
