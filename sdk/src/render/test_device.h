// Test helper: a Device with the Vulkan validation layer on, whose messages fail the test.
//
//   auto device = penumbra::test::validated_device();   // skips nothing: fails if Vulkan is absent
//   ... render ...
//   EXPECT_NO_VALIDATION_MESSAGES(*device);
#pragma once

#include <memory>

#include <gtest/gtest.h>

#include "penumbra/render/device.h"

namespace penumbra::test {

inline std::unique_ptr<Device> validated_device() {
  DeviceOptions options;
  options.validation = true;
  auto device = Device::create(options);
  EXPECT_TRUE(device.ok()) << (device.ok() ? "" : device.error().message);
  return device.ok() ? std::move(device.value()) : nullptr;
}

}  // namespace penumbra::test

#define EXPECT_NO_VALIDATION_MESSAGES(device)                                         \
  EXPECT_EQ((device).validation_messages(), 0u)                                        \
      << "Vulkan validation reported: " << (device).last_validation_message()
