// The VkResult -> message mapping users see when a device fails: one line, naming the call and
// the result, and saying what to do.
#include "blobvk/vk/device/error.h"

#include <gtest/gtest.h>

#include <string>

namespace {

using blobvk::vk::VulkanError;

VulkanError thrown(VkResult result, const char* what) {
  try {
    blobvk::vk::check(result, what);
  } catch (const VulkanError& e) {
    return e;
  }
  ADD_FAILURE() << "check(" << int(result) << ") did not throw";
  return VulkanError("");
}

void expectActionable(VkResult result, const char* name, const std::string& advice) {
  const VulkanError e = thrown(result, "vkQueueSubmit");
  const std::string message = e.what();
  EXPECT_EQ(e.result(), result);
  EXPECT_EQ(message.find('\n'), std::string::npos) << "not one line: " << message;
  EXPECT_NE(message.find("vkQueueSubmit"), std::string::npos) << message;
  EXPECT_NE(message.find(name), std::string::npos) << message;
  EXPECT_NE(message.find(advice), std::string::npos) << message;
  EXPECT_LT(message.size(), 200u) << "too long for one terminal line: " << message;
}

TEST(VulkanErrors, DeviceLostSaysWhatToLower) {
  expectActionable(VK_ERROR_DEVICE_LOST, "VK_ERROR_DEVICE_LOST", "lower the resolution");
}

TEST(VulkanErrors, OutOfDeviceMemorySaysWhatToLower) {
  expectActionable(VK_ERROR_OUT_OF_DEVICE_MEMORY, "VK_ERROR_OUT_OF_DEVICE_MEMORY",
                   "lower the resolution");
}

TEST(VulkanErrors, NoDriverNamesThePackage) {
  expectActionable(VK_ERROR_INCOMPATIBLE_DRIVER, "VK_ERROR_INCOMPATIBLE_DRIVER",
                   "mesa-vulkan-drivers");
}

TEST(VulkanErrors, MissingLayerNamesThePackage) {
  expectActionable(VK_ERROR_LAYER_NOT_PRESENT, "VK_ERROR_LAYER_NOT_PRESENT",
                   "vulkan-validationlayers");
}

TEST(VulkanErrors, UnknownCodesStillThrowWithTheCall) {
  const VulkanError e = thrown(VkResult(-123456), "vkSomething");
  EXPECT_EQ(e.result(), VkResult(-123456));
  EXPECT_NE(std::string(e.what()).find("vkSomething"), std::string::npos) << e.what();
}

TEST(VulkanErrors, SuccessAndStatusCodesDoNotThrow) {
  EXPECT_NO_THROW(blobvk::vk::check(VK_SUCCESS, "vkCall"));
  EXPECT_NO_THROW(blobvk::vk::check(VK_INCOMPLETE, "vkCall"));  // positive: a status, not an error
  EXPECT_NO_THROW(blobvk::vk::check(VK_TIMEOUT, "vkCall"));
}

}  // namespace
