#include "blobvk/vk/device/dispatch.h"

#include "blobvk/vk/device/error.h"

#include <string>

namespace blobvk::vk {

Dispatch loadDispatch(PFN_vkGetInstanceProcAddr getInstanceProcAddr, VkInstance instance,
                      VkDevice device) {
  if (!getInstanceProcAddr) throw VulkanError("HostContext.getInstanceProcAddr is null");
  Dispatch d;
  auto missing = [](const char* name) {
    throw VulkanError(std::string("Vulkan driver lacks ") + name);
  };
#define BLOBVK_VK_LOAD_INSTANCE(name)                                                  \
  d.name = reinterpret_cast<PFN_##name>(getInstanceProcAddr(instance, #name));         \
  if (!d.name) missing(#name);
  BLOBVK_VK_INSTANCE_FUNCTIONS(BLOBVK_VK_LOAD_INSTANCE)
#undef BLOBVK_VK_LOAD_INSTANCE
#define BLOBVK_VK_LOAD_DEVICE(name)                                                    \
  d.name = reinterpret_cast<PFN_##name>(d.vkGetDeviceProcAddr(device, #name));         \
  if (!d.name) missing(#name);
  BLOBVK_VK_DEVICE_FUNCTIONS(BLOBVK_VK_LOAD_DEVICE)
#undef BLOBVK_VK_LOAD_DEVICE
  return d;
}

}  // namespace blobvk::vk
