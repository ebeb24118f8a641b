#include "json_report.h"

#include "cli_conventions.h"

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/device/standalone.h"
#endif

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::app {

nlohmann::json versionJson() { return {{"blobvk_version", BLOBVK_VERSION}}; }

#ifdef BLOBVK_HAVE_VULKAN
namespace {

std::string versionText(std::uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

bool hasExtension(VkPhysicalDevice physical, const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> extensions(count);
  if (vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data()) != VK_SUCCESS) return false;
  for (const auto& e : extensions)
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

}  // namespace

nlohmann::json deviceJson(VkPhysicalDevice physical) {
  VkPhysicalDeviceProperties base{};
  vkGetPhysicalDeviceProperties(physical, &base);
  // The driver's own name and version text are Vulkan 1.2 (or VK_KHR_driver_properties) data.
  const bool driverProperties = VK_API_VERSION_MINOR(base.apiVersion) >= 2 || VK_API_VERSION_MAJOR(base.apiVersion) > 1 ||
                                hasExtension(physical, VK_KHR_DRIVER_PROPERTIES_EXTENSION_NAME);
  VkPhysicalDeviceDriverProperties driver{};
  driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
  VkPhysicalDeviceSubgroupProperties subgroup{};
  subgroup.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
  subgroup.pNext = driverProperties ? &driver : nullptr;
  VkPhysicalDeviceProperties2 props{};
  props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  props.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(physical, &props);
  const VkPhysicalDeviceLimits& l = base.limits;
  nlohmann::json out{{"name", printable(base.deviceName)},
                     {"type", vk::deviceTypeName(base.deviceType)},
                     {"api_version", versionText(base.apiVersion)},
                     {"driver_version", base.driverVersion},
                     {"vendor_id", base.vendorID},
                     {"device_id", base.deviceID},
                     {"subgroup_size", subgroup.subgroupSize},
                     {"limits",
                      {{"max_storage_buffer_range", l.maxStorageBufferRange},
                       {"max_compute_work_group_invocations", l.maxComputeWorkGroupInvocations},
                       {"max_compute_shared_memory_size", l.maxComputeSharedMemorySize},
                       {"max_image_dimension_2d", l.maxImageDimension2D}}}};
  if (driverProperties) {
    out["driver_name"] = printable(driver.driverName);
    out["driver_info"] = printable(driver.driverInfo);
  }
  // Heaps and the types in them: where work buffers and read-back memory can live
  // (vk/device/memory.h ranks them per use).
  VkPhysicalDeviceMemoryProperties memory{};
  vkGetPhysicalDeviceMemoryProperties(physical, &memory);
  nlohmann::json heaps = nlohmann::json::array();
  for (std::uint32_t h = 0; h < memory.memoryHeapCount; ++h) {
    nlohmann::json types = nlohmann::json::array();
    for (std::uint32_t t = 0; t < memory.memoryTypeCount; ++t) {
      if (memory.memoryTypes[t].heapIndex != h) continue;
      const VkMemoryPropertyFlags f = memory.memoryTypes[t].propertyFlags;
      nlohmann::json flags = nlohmann::json::array();
      if (f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) flags.push_back("device-local");
      if (f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) flags.push_back("host-visible");
      if (f & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) flags.push_back("host-coherent");
      if (f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT) flags.push_back("host-cached");
      types.push_back({{"index", t}, {"flags", flags}});
    }
    heaps.push_back({{"bytes", memory.memoryHeaps[h].size},
                     {"device_local", (memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) != 0},
                     {"types", types}});
  }
  out["memory_heaps"] = heaps;
  return out;
}

nlohmann::json allDevicesJson() {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "blobvk devices";
  app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  info.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  if (vkCreateInstance(&info, nullptr, &instance) != VK_SUCCESS) {
    throw std::runtime_error("no Vulkan driver: cannot create an instance (install mesa-vulkan-drivers for lavapipe)");
  }
  nlohmann::json out = nlohmann::json::array();
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(instance, &count, devices.data());
  for (std::uint32_t i = 0; i < count; ++i) {
    nlohmann::json d = deviceJson(devices[i]);
    d["index"] = i;
    out.push_back(std::move(d));
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}
#endif

}  // namespace blobvk::app
