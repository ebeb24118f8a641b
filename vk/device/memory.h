// A small device-memory sub-allocator (Debian 12 has no VMA): VkDeviceMemory blocks per memory
// type, first-fit free lists inside them, dedicated allocations for big buffers. Host-visible
// blocks stay mapped for their lifetime.
//
// Freed VkDeviceMemory (dedicated allocations, emptied blocks) is retained up to a limit and
// reused by the next allocation of its type and size class: a steady stream of meshes of one
// size then allocates nothing. On a discrete GPU vkAllocateMemory of hundreds of MiB, and above
// all of pinned host memory for read-backs, costs milliseconds each; on lavapipe fresh memory
// costs a page fault per page. Retained memory is given back before any allocation would fail
// or pass a heap's budget, and on request (releaseRetained).
//
// Memory types are chosen per use (rankMemoryTypes): device-local work buffers, write-combined
// staging for uploads, host-cached memory for read-backs. When an allocation fails with out of
// memory, or would take a heap past its budget (VK_EXT_memory_budget when the device has it, the
// heap's size otherwise), the next suitable type is tried before giving up.
#pragma once

#include "blobvk/vk/device/dispatch.h"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace blobvk::vk {

enum class MemoryUse {
  DeviceLocal,  // work buffers: device-local; mapped only where that costs nothing (UMA, lavapipe)
  Upload,       // staging the host writes once and the device reads: host-visible and coherent
  Readback,     // the device writes, the host reads: host-visible, coherent, cached if possible
};

// The memory types of `properties` allowed by `typeBits` that suit `use`, best first:
// - DeviceLocal: device-local types of the largest device-local heap (host-visible first, so
//   unified memory skips staging), then the other device-local ones (a 256 MiB BAR heap), then
//   any other type the device can use (host memory over the bus) as a last resort.
// - Upload: host-visible coherent, not device-local first (the BAR heap stays for work buffers),
//   uncached first (write-combined).
// - Readback: host-visible coherent, cached first, not device-local first.
// A pure function of the layout, so a discrete GPU's can be tested on any machine.
std::vector<std::uint32_t> rankMemoryTypes(const VkPhysicalDeviceMemoryProperties& properties,
                                           std::uint32_t typeBits, MemoryUse use);

// A memory layout presented to the allocator instead of the device's, for tests of discrete-GPU
// behaviour on lavapipe: every simulated type allocates from the device's type `realType`;
// simulated types without HOST_VISIBLE are never mapped (so uploads and read-backs stage).
inline constexpr std::uint32_t kAnyMappableRealType = ~0u;
struct MemorySimulation {
  VkPhysicalDeviceMemoryProperties properties{};
  // The device's type every simulated type allocates from; by default its first HOST_VISIBLE |
  // HOST_COHERENT type, so simulated host-visible types can be mapped on any device.
  std::uint32_t realType = kAnyMappableRealType;
  // Per simulated heap, the bytes this process may use as VK_EXT_memory_budget would report
  // (heapBudget); empty: the heap sizes.
  std::vector<VkDeviceSize> heapBudget;
  // Called before each VkDeviceMemory allocation; true makes it fail with
  // VK_ERROR_OUT_OF_DEVICE_MEMORY (as a full heap does).
  std::function<bool(std::uint32_t type, VkDeviceSize bytes)> refuse;
};

struct Allocation {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // non-null when host visible
  std::uint32_t block = ~0u;  // owner block (~0u: dedicated)
  VkDeviceSize memorySize = 0;  // dedicated: the VkDeviceMemory's size (`size` rounded to its class)
  std::uint32_t type = 0;     // memory type (the simulated one under a MemorySimulation)
  bool hostCached = false;    // mapped memory the host reads fast (else: go through Readback)
};

class MemoryAllocator {
 public:
  MemoryAllocator(const Dispatch& d, VkPhysicalDevice physical, VkDevice device,
                  VkDeviceSize blockSize = 64ull << 20, const MemorySimulation* simulation = nullptr);
  ~MemoryAllocator();
  MemoryAllocator(const MemoryAllocator&) = delete;
  MemoryAllocator& operator=(const MemoryAllocator&) = delete;

  // Throws VulkanError (VK_ERROR_OUT_OF_DEVICE_MEMORY) when every suitable type failed or is at
  // its heap's budget.
  Allocation allocate(const VkMemoryRequirements& req, MemoryUse use);
  void free(const Allocation& a);

  const VkPhysicalDeviceMemoryProperties& properties() const { return props_; }
  bool hasBudgetExtension() const { return budgetExtension_; }
  // Bytes of VkDeviceMemory this allocator holds in a heap (blocks and dedicated allocations).
  VkDeviceSize heapBytes(std::uint32_t heap) const { return heapBytes_[heap]; }
  VkDeviceSize bytesInUse() const { return inUse_; }
  std::size_t blockCount() const;

  // Freed memory kept for reuse (counted in heapBytes): at most `hostBytes` of the host's memory
  // (system RAM: every heap of a CPU driver or an integrated GPU, a discrete GPU's system heap)
  // and at most `deviceBytes` of a discrete GPU's own (its device-local heaps, BAR-mapped types
  // included); 0 retains nothing. The one-argument form sets both.
  void setRetainLimit(VkDeviceSize bytes) { setRetainLimits(bytes, bytes); }
  void setRetainLimits(VkDeviceSize hostBytes, VkDeviceSize deviceBytes);
  VkDeviceSize retainLimit() const { return retainLimit_[0]; }
  VkDeviceSize deviceRetainLimit() const { return retainLimit_[1]; }
  VkDeviceSize retainedBytes() const { return retainedBytes_[0] + retainedBytes_[1]; }
  // Gives every retained VkDeviceMemory back to the driver.
  void releaseRetained();

 private:
  struct Range { VkDeviceSize offset, size; };
  struct Retained {
    VkDeviceMemory memory;
    std::uint32_t type;
    VkDeviceSize size;
    void* mapped;
  };
  struct Block {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    std::uint32_t type = 0;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
    std::vector<Range> freeRanges;  // sorted by offset, coalesced
  };
  bool withinBudget(std::uint32_t type, VkDeviceSize bytes) const;
  // A VkDeviceMemory of `type`, mapped when host visible; VK_NULL_HANDLE when the driver (or the
  // simulation) reports out of memory, so the caller can try the next type.
  VkDeviceMemory allocateMemory(std::uint32_t type, VkDeviceSize size, void** mapped);
  // Memory of `type` and exactly `size` from the retained list, or VK_NULL_HANDLE.
  VkDeviceMemory reuseRetained(std::uint32_t type, VkDeviceSize size, void** mapped);
  // Retains the memory (oldest retained memory freed past the limit) or frees it.
  void releaseMemory(std::uint32_t type, VkDeviceSize size, VkDeviceMemory memory, void* mapped);
  void freeMemory(std::uint32_t type, VkDeviceSize size, VkDeviceMemory memory);
  bool allocateInBlocks(const VkMemoryRequirements& req, std::uint32_t type, Allocation& a);
  VkDeviceSize blockSizeFor(std::uint32_t type) const;

  const Dispatch& d_;
  VkPhysicalDevice physical_;
  VkDevice device_;
  VkPhysicalDeviceMemoryProperties props_{};
  std::unique_ptr<MemorySimulation> simulation_;
  bool budgetExtension_ = false;
  bool separateHostHeap_ = false;  // some heap is not device-local (a discrete GPU's system memory)
  VkDeviceSize blockSize_;
  VkDeviceSize inUse_ = 0;
  std::array<VkDeviceSize, VK_MAX_MEMORY_HEAPS> heapBytes_{};
  std::vector<Block> blocks_;
  // Which retention pool a type's memory is in: 0 the host's memory, 1 a discrete GPU's own.
  int retainPool(std::uint32_t type) const;

  std::vector<Retained> retained_;  // oldest first
  std::array<VkDeviceSize, 2> retainedBytes_{};  // by retainPool
  std::array<VkDeviceSize, 2> retainLimit_{};
};

}  // namespace blobvk::vk
