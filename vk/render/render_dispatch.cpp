#include "blobvk/vk/render/render_dispatch.h"

#include "blobvk/vk/device/error.h"

#include <string>

namespace blobvk::vk {

RenderDispatch loadRenderDispatch(PFN_vkGetInstanceProcAddr getInstanceProcAddr,
                                  VkInstance instance, VkDevice device) {
  if (!getInstanceProcAddr) throw VulkanError("HostContext.getInstanceProcAddr is null");
  auto getDeviceProcAddr = reinterpret_cast<PFN_vkGetDeviceProcAddr>(
      getInstanceProcAddr(instance, "vkGetDeviceProcAddr"));
  if (!getDeviceProcAddr) throw VulkanError("Vulkan driver lacks vkGetDeviceProcAddr");
  RenderDispatch d;
  auto missing = [](const char* name) {
    throw VulkanError(std::string("Vulkan driver lacks ") + name);
  };
  // vkGetPhysicalDeviceFormatProperties is an instance-level function; the rest are device-level.
  d.vkGetPhysicalDeviceFormatProperties = reinterpret_cast<PFN_vkGetPhysicalDeviceFormatProperties>(
      getInstanceProcAddr(instance, "vkGetPhysicalDeviceFormatProperties"));
  if (!d.vkGetPhysicalDeviceFormatProperties) missing("vkGetPhysicalDeviceFormatProperties");
#define BLOBVK_VK_LOAD_DEVICE(name)                                                       \
  if (!d.name) {                                                                          \
    d.name = reinterpret_cast<PFN_##name>(getDeviceProcAddr(device, #name));              \
    if (!d.name) missing(#name);                                                          \
  }
  BLOBVK_VK_RENDER_FUNCTIONS(BLOBVK_VK_LOAD_DEVICE)
#undef BLOBVK_VK_LOAD_DEVICE
  return d;
}

}  // namespace blobvk::vk
