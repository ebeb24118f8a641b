// A headless instance and device for the CLI and tests: no window system, one compute queue.
#pragma once

#include "blobvk/vk/device/context.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace blobvk::vk {

struct PipelineCacheKey;  // vk/device/pipeline_cache_file.h

struct StandaloneOptions {
  // Device by index into listDevices() ("0") or by a case-insensitive substring of its name
  // ("llvmpipe"). Empty: the first discrete GPU, else integrated, else virtual, else CPU.
  std::string device;
  // VK_LAYER_KHRONOS_validation with its core checks and synchronisation validation, and a
  // counting debug messenger.
  bool validation = false;
  bool printValidationMessages = true;  // echo each message to stderr
  // Pipeline cache on disk, loaded at creation and saved at destruction (temp file + rename),
  // one file per device, driver and blobvk version (vk/device/pipeline_cache_file.h). "" (default):
  // $BLOBVK_PIPELINE_CACHE, else $XDG_CACHE_HOME/blobvk, else ~/.cache/blobvk; "off": none; else
  // the directory to use. A corrupt, truncated or foreign file is ignored with one warning line
  // on stderr and replaced on save; failing to save is one warning line too, never an error.
  std::string pipelineCache;
};

class StandaloneContext {
 public:
  explicit StandaloneContext(const StandaloneOptions& options = {});
  ~StandaloneContext();
  StandaloneContext(const StandaloneContext&) = delete;
  StandaloneContext& operator=(const StandaloneContext&) = delete;

  Device& device() { return *device_; }
  const HostContext& host() const { return host_; }
  // Validation messages of warning or error severity since creation (0 without validation).
  std::uint32_t validationMessages() const;
  // The message id name of the last of them (e.g. "SYNC-HAZARD-WRITE-AFTER-WRITE"); empty if none.
  std::string lastValidationMessageId() const;
  bool validationEnabled() const { return messenger_ != VK_NULL_HANDLE; }
  // The pipeline cache file in use (empty when off), and the bytes of Vulkan cache data loaded
  // from it at creation (0: none, or it was ignored).
  const std::filesystem::path& pipelineCacheFile() const { return cacheFile_; }
  std::size_t pipelineCacheBytesLoaded() const { return cacheLoaded_.size(); }

 public:
  struct Counters;  // validation message counts, shared with the debug callback

 private:
  void release();
  void savePipelineCache() noexcept;
  HostContext host_;
  std::filesystem::path cacheFile_;
  std::unique_ptr<PipelineCacheKey> cacheKey_;
  std::vector<std::uint8_t> cacheLoaded_;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  std::unique_ptr<Counters> counters_;
  std::unique_ptr<Device> device_;
};

// Every physical device the loader sees (creates and destroys a temporary instance). Throws
// VulkanError when there is no Vulkan driver at all.
std::vector<DeviceInfo> listDevices();

// --devices: "all" (every device of `infos` except CPU, i.e. software, ones when a GPU is there),
// or a comma-separated list of requests, each an index into `infos` or a case-insensitive
// substring of a name (as StandaloneOptions::device). A device named twice is meant to be opened
// twice (one StandaloneContext each: how one GPU, or lavapipe, runs as several devices). Returns
// indices into `infos` in list order; throws VulkanError naming the list and the entry at fault
// (an empty entry, no match, an index out of range, more than kMaxListedDevices entries).
inline constexpr std::size_t kMaxListedDevices = 64;
std::vector<std::size_t> resolveDeviceList(const std::string& list, const std::vector<DeviceInfo>& infos);

// True when a Vulkan instance with at least one device can be created (tests skip otherwise).
bool vulkanAvailable(std::string* why = nullptr);

const char* deviceTypeName(VkPhysicalDeviceType type);

}  // namespace blobvk::vk
