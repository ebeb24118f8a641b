// A headless instance and device for the CLI and tests: no window system, one compute queue.
#pragma once

#include "blobvk/vk/context.h"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace blobvk::vk {

struct StandaloneOptions {
  // Device by index into listDevices() ("0") or by a case-insensitive substring of its name
  // ("llvmpipe"). Empty: the first discrete GPU, else integrated, else virtual, else CPU.
  std::string device;
  // VK_LAYER_KHRONOS_validation with its core checks and synchronisation validation, and a
  // counting debug messenger.
  bool validation = false;
  bool printValidationMessages = true;  // echo each message to stderr
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

 public:
  struct Counters;  // validation message counts, shared with the debug callback

 private:
  void release();
  HostContext host_;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  std::unique_ptr<Counters> counters_;
  std::unique_ptr<Device> device_;
};

// Every physical device the loader sees (creates and destroys a temporary instance). Throws
// VulkanError when there is no Vulkan driver at all.
std::vector<DeviceInfo> listDevices();

// True when a Vulkan instance with at least one device can be created (tests skip otherwise).
bool vulkanAvailable(std::string* why = nullptr);

const char* deviceTypeName(VkPhysicalDeviceType type);

}  // namespace blobvk::vk
