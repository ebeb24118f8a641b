// `blobvk devices`: the Vulkan devices the loader sees and the limits blobvk cares about.
#include "commands.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <stdexcept>

#ifdef BLOBVK_HAVE_VULKAN
#include "vk/standalone.h"
#endif

namespace blobvk::app {

void addDevicesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("devices", "List Vulkan devices and their limits");
  cmd->callback([] {
#ifdef BLOBVK_HAVE_VULKAN
    const auto devices = vk::listDevices();
    for (std::size_t i = 0; i < devices.size(); ++i) {
      const auto& d = devices[i];
      std::printf("[%zu] %s (%s), Vulkan %u.%u.%u\n", i, d.name.c_str(), vk::deviceTypeName(d.type),
                  VK_API_VERSION_MAJOR(d.apiVersion), VK_API_VERSION_MINOR(d.apiVersion),
                  VK_API_VERSION_PATCH(d.apiVersion));
      std::printf("    maxStorageBufferRange %u, maxComputeWorkGroupInvocations %u, maxComputeSharedMemorySize %u, subgroupSize %u\n",
                  d.limits.maxStorageBufferRange, d.limits.maxComputeWorkGroupInvocations, d.limits.maxComputeSharedMemorySize, d.subgroupSize);
    }
    if (devices.empty()) std::printf("no Vulkan devices (install mesa-vulkan-drivers for lavapipe)\n");
#else
    throw std::runtime_error("this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
  });
}

}  // namespace blobvk::app
