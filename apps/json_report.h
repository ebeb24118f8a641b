// Pieces shared by the --json outputs: the blobvk version, and a Vulkan device described with its
// driver (so a report says what produced it).
#pragma once

#include <nlohmann/json.hpp>

#ifdef BLOBVK_HAVE_VULKAN
#include <vulkan/vulkan.h>
#endif

namespace blobvk::app {

// {"blobvk_version": "0.1.0"}: the start of every JSON report.
nlohmann::json versionJson();

#ifdef BLOBVK_HAVE_VULKAN
// name, type, api_version, driver_version and, where the device reports them (Vulkan 1.2 or
// VK_KHR_driver_properties), driver_name and driver_info ("Mesa 22.3.6 (LLVM 15.0.6)"), plus the
// limits blobvk cares about.
nlohmann::json deviceJson(VkPhysicalDevice physical);

// Every device the loader sees, in listDevices() order (a temporary instance); throws with the
// mesa-vulkan-drivers hint when no instance can be created.
nlohmann::json allDevicesJson();
#endif

}  // namespace blobvk::app
