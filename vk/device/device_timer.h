// Device time between marks recorded into command buffers (timestamp queries): what the device
// spent on each phase of a job, apart from the host's submits, waits and copies. Marks may span
// several submits of one Device; read the intervals after the last submit's fence.
#pragma once

#include "blobvk/vk/device/context.h"

#include <cstdint>

namespace blobvk::vk {

class DeviceTimer {
 public:
  // Room for `marks` marks. Without timestamps on the Device's queue every call does nothing
  // and seconds() is 0.
  DeviceTimer(Device& device, std::uint32_t marks);
  ~DeviceTimer();
  DeviceTimer(const DeviceTimer&) = delete;
  DeviceTimer& operator=(const DeviceTimer&) = delete;

  bool enabled() const { return pool_ != VK_NULL_HANDLE; }
  // Resets every mark; record once, before the first mark (first submit).
  void reset(Recorder& rec);
  // Mark `index`: written when every command recorded before it has completed.
  void mark(Recorder& rec, std::uint32_t index);
  // Seconds of device time from mark `from` to mark `to` (both recorded and executed).
  double seconds(std::uint32_t from, std::uint32_t to);

 private:
  Device& device_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  std::uint32_t marks_ = 0;
};

}  // namespace blobvk::vk
