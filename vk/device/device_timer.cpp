#include "blobvk/vk/device/device_timer.h"

#include "blobvk/vk/device/error.h"

#include <vector>

namespace blobvk::vk {

DeviceTimer::DeviceTimer(Device& device, std::uint32_t marks) : device_(device), marks_(marks) {
  if (device.timestampPeriodNs() <= 0.0 || marks == 0) return;
  VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = marks;
  check(device.d().vkCreateQueryPool(device.handle(), &info, nullptr, &pool_), "vkCreateQueryPool");
}

DeviceTimer::~DeviceTimer() {
  if (pool_) device_.d().vkDestroyQueryPool(device_.handle(), pool_, nullptr);
}

void DeviceTimer::reset(Recorder& rec) {
  if (pool_) device_.d().vkCmdResetQueryPool(rec.cmd(), pool_, 0, marks_);
}

void DeviceTimer::mark(Recorder& rec, std::uint32_t index) {
  // Bottom of pipe: the timestamp is written once all earlier commands have finished.
  if (pool_) device_.d().vkCmdWriteTimestamp(rec.cmd(), VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, pool_, index);
}

double DeviceTimer::seconds(std::uint32_t from, std::uint32_t to) {
  if (!pool_) return 0.0;
  std::uint64_t ticks[2] = {0, 0};
  for (int i = 0; i < 2; ++i) {
    check(device_.d().vkGetQueryPoolResults(device_.handle(), pool_, i ? to : from, 1, sizeof(std::uint64_t),
                                            &ticks[i], sizeof(std::uint64_t),
                                            VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults");
  }
  return ticks[1] >= ticks[0] ? double(ticks[1] - ticks[0]) * device_.timestampPeriodNs() * 1e-9 : 0.0;
}

}  // namespace blobvk::vk
