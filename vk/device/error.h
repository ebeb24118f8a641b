// Vulkan failures as exceptions with one-line messages that say what to do about them.
#pragma once

#include <vulkan/vulkan_core.h>

#include <stdexcept>
#include <string>

namespace blobvk::vk {

// Thrown for every Vulkan failure; result() is VK_SUCCESS for non-API errors (missing feature,
// no device, bad argument).
class VulkanError : public std::runtime_error {
 public:
  VulkanError(const std::string& message, VkResult result = VK_SUCCESS)
      : std::runtime_error(message), result_(result) {}
  VkResult result() const { return result_; }

 private:
  VkResult result_;
};

// Name of a VkResult ("VK_ERROR_DEVICE_LOST").
const char* resultName(VkResult result);

[[noreturn]] void throwVulkanError(VkResult result, const char* what);

// Throws VulkanError when result is an error; `what` names the call ("vkCreateDevice").
inline void check(VkResult result, const char* what) {
  if (result < 0) [[unlikely]]
    throwVulkanError(result, what);
}

}  // namespace blobvk::vk
