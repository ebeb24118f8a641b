#include "blobvk/vk/device/error.h"

namespace blobvk::vk {

const char* resultName(VkResult result) {
  switch (result) {
#define BLOBVK_CASE(r) \
  case r:              \
    return #r;
    BLOBVK_CASE(VK_SUCCESS)
    BLOBVK_CASE(VK_NOT_READY)
    BLOBVK_CASE(VK_TIMEOUT)
    BLOBVK_CASE(VK_INCOMPLETE)
    BLOBVK_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    BLOBVK_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    BLOBVK_CASE(VK_ERROR_INITIALIZATION_FAILED)
    BLOBVK_CASE(VK_ERROR_DEVICE_LOST)
    BLOBVK_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    BLOBVK_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    BLOBVK_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    BLOBVK_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    BLOBVK_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    BLOBVK_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    BLOBVK_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    BLOBVK_CASE(VK_ERROR_FRAGMENTED_POOL)
    BLOBVK_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
#undef BLOBVK_CASE
    default:
      return "VK_ERROR_UNKNOWN";
  }
}

void throwVulkanError(VkResult result, const char* what) {
  std::string message = std::string(what) + " failed: " + resultName(result);
  switch (result) {
    case VK_ERROR_DEVICE_LOST:
      message += " (the driver reset or crashed the device; a too-long dispatch can trigger the "
                 "GPU watchdog: lower the resolution or the brick size)";
      break;
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      message += " (out of device memory: lower the resolution or the brick size)";
      break;
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      message += " (out of host memory)";
      break;
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      message += " (no Vulkan 1.1 driver: install mesa-vulkan-drivers or check VK_ICD_FILENAMES)";
      break;
    case VK_ERROR_LAYER_NOT_PRESENT:
      message += " (validation layer missing: install vulkan-validationlayers)";
      break;
    default:
      break;
  }
  throw VulkanError(message, result);
}

}  // namespace blobvk::vk
