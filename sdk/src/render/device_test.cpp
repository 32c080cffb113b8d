#include "penumbra/render/device.h"

#include <gtest/gtest.h>

#include "test_device.h"

namespace penumbra {
namespace {

TEST(Device, CreatesWithValidationAndSubmits) {
  auto device = test::validated_device();
  ASSERT_TRUE(device);
  EXPECT_FALSE(device->name().empty());
  EXPECT_NE(device->device(), VK_NULL_HANDLE);
  EXPECT_NE(device->queue(), VK_NULL_HANDLE);
  bool recorded = false;
  Status s = device->submit_and_wait([&](VkCommandBuffer cmd) { recorded = cmd != VK_NULL_HANDLE; });
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_TRUE(recorded);
  EXPECT_NO_VALIDATION_MESSAGES(*device);
}

// The counter the tests rely on does count: an invalid call (a zero-sized buffer) is reported.
TEST(Device, CountsValidationMessages) {
  auto device = test::validated_device();
  ASSERT_TRUE(device);
  ASSERT_EQ(device->validation_messages(), 0u);
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = 0;  // VUID-VkBufferCreateInfo-size-00912
  info.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  (void)vkCreateBuffer(device->device(), &info, nullptr, &buffer);
  if (buffer) vkDestroyBuffer(device->device(), buffer, nullptr);
  EXPECT_GE(device->validation_messages(), 1u);
  EXPECT_NE(device->last_validation_message().find("size"), std::string::npos)
      << device->last_validation_message();
}

TEST(Device, MeetsTheRendererRequirements) {
  auto device = test::validated_device();
  ASSERT_TRUE(device);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(device->physical_device(), &props);
  EXPECT_GE(props.apiVersion, VK_API_VERSION_1_3);
  EXPECT_EQ(device->is_software(), props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU);
}

}  // namespace
}  // namespace penumbra
