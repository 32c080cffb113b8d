// Vulkan helpers of the renderer and its render features (render/feature.h): result names,
// memory allocation (one allocation per resource, enough at this scale; every byte is counted),
// buffers, images and barriers.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"

namespace penumbra::vk {

const char* vk_result_name(VkResult r);

// A buffer with its own memory; host-visible ones stay mapped.
struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;   // requested
  VkDeviceSize bytes = 0;  // allocated
  void* mapped = nullptr;
};
struct ImageResource {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkDeviceSize bytes = 0;
};

// Owns the allocations of one user (the renderer) and counts their bytes.
class Allocator {
 public:
  Allocator(VkPhysicalDevice physical, VkDevice device);
  // Host-visible, coherent and mapped when `host` (uploads, per-frame data, readback), else device-local.
  Result<Buffer> create_buffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host);
  Result<ImageResource> create_image(const VkImageCreateInfo& info, VkImageViewType view_type,
                                     VkImageAspectFlags aspect);
  void destroy(Buffer& buffer);
  void destroy(ImageResource& image);
  std::uint64_t bytes() const { return bytes_; }
  VkDevice device() const { return device_; }

 private:
  Result<VkDeviceMemory> allocate(const VkMemoryRequirements& req, VkMemoryPropertyFlags flags);
  VkPhysicalDeviceMemoryProperties memory_{};
  VkDevice device_;
  std::uint64_t bytes_ = 0;
};

// One synchronization2 image layout transition covering every mip level and layer.
void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from,
                   VkImageLayout to, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

}  // namespace penumbra::vk

namespace penumbra {
using vk::vk_result_name;
}

namespace penumbra::vk {
// A zero-initialised Vulkan info struct with its sType set.
template <class T>
T vk_struct(VkStructureType type) {
  T value{};
  value.sType = type;
  return value;
}
}  // namespace penumbra::vk
