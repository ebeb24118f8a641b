// A small device-memory sub-allocator (Debian 12 has no VMA): large VkDeviceMemory blocks per
// memory type, first-fit free lists inside them, dedicated allocations for big buffers. Host-
// visible blocks stay mapped for their lifetime.
#pragma once

#include "vk/dispatch.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::vk {

enum class MemoryUse {
  DeviceLocal,  // GPU-only data; may not be mappable (discrete GPUs): upload through staging
  HostVisible,  // staging and readback: mappable and coherent
};

struct Allocation {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // non-null when host visible
  std::uint32_t block = ~0u;  // owner block (~0u: dedicated)
};

class MemoryAllocator {
 public:
  MemoryAllocator(const Dispatch& d, VkPhysicalDevice physical, VkDevice device,
                  VkDeviceSize blockSize = 64ull << 20);
  ~MemoryAllocator();
  MemoryAllocator(const MemoryAllocator&) = delete;
  MemoryAllocator& operator=(const MemoryAllocator&) = delete;

  Allocation allocate(const VkMemoryRequirements& req, MemoryUse use);
  void free(const Allocation& a);

  // True when device-local memory is also host visible (lavapipe, integrated GPUs, ReBAR).
  bool deviceLocalIsMappable() const { return unifiedMemory_; }
  VkDeviceSize bytesInUse() const { return inUse_; }
  std::size_t blockCount() const;

 private:
  struct Range { VkDeviceSize offset, size; };
  struct Block {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    std::uint32_t type = 0;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
    std::vector<Range> freeRanges;  // sorted by offset, coalesced
  };
  std::uint32_t pickType(std::uint32_t typeBits, MemoryUse use) const;
  VkDeviceMemory allocateMemory(std::uint32_t type, VkDeviceSize size, void** mapped);

  const Dispatch& d_;
  VkDevice device_;
  VkPhysicalDeviceMemoryProperties props_{};
  VkDeviceSize blockSize_;
  VkDeviceSize inUse_ = 0;
  bool unifiedMemory_ = false;
  std::vector<Block> blocks_;
};

}  // namespace blobvk::vk
