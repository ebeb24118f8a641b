// `blobvk devices [--json]`: the Vulkan devices the loader sees, their drivers and the limits
// blobvk cares about. The index is what --device takes.
#include "cli_conventions.h"
#include "commands.h"
#include "json_report.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

namespace blobvk::app {

void addDevicesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("devices", "List Vulkan devices, their drivers and limits");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "Print the list as JSON (with the blobvk version)");
  cmd->callback([json] {
#ifdef BLOBVK_HAVE_VULKAN
    const nlohmann::json devices = allDevicesJson();
    if (*json) {
      nlohmann::json out = versionJson();
      out["devices"] = devices;
      std::printf("%s\n", out.dump(2).c_str());
      return;
    }
    for (const auto& d : devices) {
      std::printf("[%d] %s (%s), Vulkan %s", d["index"].get<int>(), d["name"].get<std::string>().c_str(),
                  d["type"].get<std::string>().c_str(), d["api_version"].get<std::string>().c_str());
      if (d.contains("driver_name")) {
        std::printf(", driver %s %s", d["driver_name"].get<std::string>().c_str(), d["driver_info"].get<std::string>().c_str());
      }
      const auto& l = d["limits"];
      std::printf("\n    maxStorageBufferRange %u, maxComputeWorkGroupInvocations %u, maxComputeSharedMemorySize %u, subgroupSize %u\n",
                  l["max_storage_buffer_range"].get<unsigned>(), l["max_compute_work_group_invocations"].get<unsigned>(),
                  l["max_compute_shared_memory_size"].get<unsigned>(), d["subgroup_size"].get<unsigned>());
      for (std::size_t h = 0; h < d["memory_heaps"].size(); ++h) {
        const auto& heap = d["memory_heaps"][h];
        std::printf("    heap %zu: %.1f GiB%s;", h, double(heap["bytes"].get<std::uint64_t>()) / (1ull << 30),
                    heap["device_local"].get<bool>() ? ", device-local" : "");
        for (const auto& t : heap["types"]) {
          std::string flags;
          for (const auto& f : t["flags"]) {
            if (!flags.empty()) flags += ' ';
            flags += f.get<std::string>();
          }
          std::printf(" type %d: %s;", t["index"].get<int>(), flags.empty() ? "-" : flags.c_str());
        }
        std::printf("\n");
      }
    }
    if (devices.empty()) std::printf("no Vulkan devices (install mesa-vulkan-drivers for lavapipe)\n");
#else
    (void)json;
    throw std::runtime_error("this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
  });
}

}  // namespace blobvk::app
