// The on-disk pipeline cache of StandaloneContext: where it lives, which file belongs to which
// device, driver and blobvk build, and a format that detects truncation, corruption and files
// from another device. Engines that embed blobvk pass their own VkPipelineCache instead
// (HostContext::pipelineCache) and keep it wherever they like.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace blobvk::vk {

// What a pipeline cache blob is valid for. The driver checks its own header (vendor, device,
// pipelineCacheUUID); the driver version and blobvk's version are ours to check, since a blob
// from an older build may hold pipelines for shaders that no longer exist (harmless but dead
// weight) and some drivers do not change the UUID with every release.
struct PipelineCacheKey {
  std::uint32_t vendorID = 0;
  std::uint32_t deviceID = 0;
  std::uint32_t driverVersion = 0;
  std::uint8_t uuid[VK_UUID_SIZE] = {};
  std::string blobvkVersion;

  // One line, also the file name's stem: "<vendor>-<device>-<driver>-<uuid>-<blobvk version>".
  std::string text() const;
};

PipelineCacheKey pipelineCacheKey(const VkPhysicalDeviceProperties& properties);

// The directory a StandaloneOptions::pipelineCache value names: "off" -> empty (no cache);
// a path -> that path; "" -> $BLOBVK_PIPELINE_CACHE if set (which may itself be "off"), else
// $XDG_CACHE_HOME/blobvk, else $HOME/.cache/blobvk, else empty.
std::filesystem::path resolvePipelineCacheDir(const std::string& option);

// The file for `key` inside `dir`, one per key: "pipelines-<key>.bin".
std::filesystem::path pipelineCacheFile(const std::filesystem::path& dir, const PipelineCacheKey& key);

// The Vulkan pipeline cache data stored in `file`, checked against `key` (blobvk's header: magic,
// format, key, payload length and checksum; then the payload's VkPipelineCacheHeaderVersionOne:
// header size and version, vendor, device and UUID). A missing file gives empty data and no
// problem; anything else that is wrong gives empty data and `problem` set to one phrase.
std::vector<std::uint8_t> readPipelineCacheFile(const std::filesystem::path& file, const PipelineCacheKey& key,
                                                std::string& problem);

// Writes `data` for `key` to `file` through a temporary file in the same directory and a rename,
// so a concurrent reader sees the old file or the new one, never a torn one. Creates the
// directory. Throws std::runtime_error naming the file on an I/O error.
void writePipelineCacheFile(const std::filesystem::path& file, const PipelineCacheKey& key,
                            std::span<const std::uint8_t> data);

}  // namespace blobvk::vk
