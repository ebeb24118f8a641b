#include "vk/memory.h"

#include "vk/error.h"

#include <algorithm>

namespace blobvk::vk {
namespace {
VkDeviceSize alignUp(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }
constexpr VkMemoryPropertyFlags kHostFlags =
    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
}  // namespace

MemoryAllocator::MemoryAllocator(const Dispatch& d, VkPhysicalDevice physical, VkDevice device,
                                 VkDeviceSize blockSize)
    : d_(d), device_(device), blockSize_(blockSize) {
  d_.vkGetPhysicalDeviceMemoryProperties(physical, &props_);
  for (std::uint32_t i = 0; i < props_.memoryTypeCount; ++i) {
    const auto f = props_.memoryTypes[i].propertyFlags;
    if ((f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) && (f & kHostFlags) == kHostFlags) {
      unifiedMemory_ = true;
    }
  }
}

MemoryAllocator::~MemoryAllocator() {
  for (auto& b : blocks_) {
    if (b.memory) d_.vkFreeMemory(device_, b.memory, nullptr);
  }
}

std::size_t MemoryAllocator::blockCount() const {
  return std::size_t(std::count_if(blocks_.begin(), blocks_.end(),
                                   [](const Block& b) { return b.memory != VK_NULL_HANDLE; }));
}

std::uint32_t MemoryAllocator::pickType(std::uint32_t typeBits, MemoryUse use) const {
  // Preference order: for device data, device-local (mappable if possible, so lavapipe and
  // integrated GPUs skip staging); for host data, coherent host-visible (cached if possible).
  auto score = [&](VkMemoryPropertyFlags f) -> int {
    const bool local = f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    const bool host = (f & kHostFlags) == kHostFlags;
    const bool cached = f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    if (use == MemoryUse::DeviceLocal) return (local ? 4 : 0) + (host ? 2 : 0) + (cached ? 1 : 0);
    if (!host) return -1;
    return 4 + (cached ? 2 : 0) + (local ? 0 : 1);
  };
  int best = -1;
  std::uint32_t bestType = ~0u;
  for (std::uint32_t i = 0; i < props_.memoryTypeCount; ++i) {
    if (!(typeBits & (1u << i))) continue;
    const int s = score(props_.memoryTypes[i].propertyFlags);
    if (s > best) best = s, bestType = i;
  }
  if (bestType == ~0u) {
    throw VulkanError("no Vulkan memory type fits a buffer (driver reports none host visible)");
  }
  return bestType;
}

VkDeviceMemory MemoryAllocator::allocateMemory(std::uint32_t type, VkDeviceSize size,
                                               void** mapped) {
  VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  info.allocationSize = size;
  info.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  check(d_.vkAllocateMemory(device_, &info, nullptr, &memory), "vkAllocateMemory");
  *mapped = nullptr;
  if ((props_.memoryTypes[type].propertyFlags & kHostFlags) == kHostFlags) {
    const VkResult r = d_.vkMapMemory(device_, memory, 0, VK_WHOLE_SIZE, 0, mapped);
    if (r < 0) {
      d_.vkFreeMemory(device_, memory, nullptr);
      check(r, "vkMapMemory");
    }
  }
  return memory;
}

Allocation MemoryAllocator::allocate(const VkMemoryRequirements& req, MemoryUse use) {
  const std::uint32_t type = pickType(req.memoryTypeBits, use);
  Allocation a;
  a.size = req.size;
  if (req.size > blockSize_ / 2) {  // dedicated: big grids get their own memory
    a.memory = allocateMemory(type, req.size, &a.mapped);
    inUse_ += req.size;
    return a;
  }
  auto tryBlock = [&](std::uint32_t bi) -> bool {
    Block& b = blocks_[bi];
    if (!b.memory || b.type != type) return false;
    for (std::size_t i = 0; i < b.freeRanges.size(); ++i) {
      Range& r = b.freeRanges[i];
      const VkDeviceSize start = alignUp(r.offset, req.alignment);
      if (start + req.size > r.offset + r.size) continue;
      const Range before{r.offset, start - r.offset};
      const Range after{start + req.size, r.offset + r.size - start - req.size};
      b.freeRanges.erase(b.freeRanges.begin() + std::ptrdiff_t(i));
      if (after.size) b.freeRanges.insert(b.freeRanges.begin() + std::ptrdiff_t(i), after);
      if (before.size) b.freeRanges.insert(b.freeRanges.begin() + std::ptrdiff_t(i), before);
      a.memory = b.memory;
      a.offset = start;
      a.block = bi;
      a.mapped = b.mapped ? static_cast<char*>(b.mapped) + start : nullptr;
      return true;
    }
    return false;
  };
  for (std::uint32_t bi = 0; bi < blocks_.size(); ++bi) {
    if (tryBlock(bi)) {
      inUse_ += req.size;
      return a;
    }
  }
  Block nb;
  nb.type = type;
  nb.size = blockSize_;
  nb.memory = allocateMemory(type, blockSize_, &nb.mapped);
  nb.freeRanges.push_back({0, blockSize_});
  std::uint32_t slot = 0;
  while (slot < blocks_.size() && blocks_[slot].memory) ++slot;
  if (slot == blocks_.size()) blocks_.push_back(std::move(nb));
  else blocks_[slot] = std::move(nb);
  tryBlock(slot);
  inUse_ += req.size;
  return a;
}

void MemoryAllocator::free(const Allocation& a) {
  if (!a.memory) return;
  inUse_ -= a.size;
  if (a.block == ~0u) {
    d_.vkFreeMemory(device_, a.memory, nullptr);
    return;
  }
  Block& b = blocks_[a.block];
  auto it = std::lower_bound(b.freeRanges.begin(), b.freeRanges.end(), a.offset,
                             [](const Range& r, VkDeviceSize off) { return r.offset < off; });
  it = b.freeRanges.insert(it, Range{a.offset, a.size});
  // Coalesce with the next and the previous range.
  if (it + 1 != b.freeRanges.end() && it->offset + it->size == (it + 1)->offset) {
    it->size += (it + 1)->size;
    b.freeRanges.erase(it + 1);
  }
  if (it != b.freeRanges.begin() && (it - 1)->offset + (it - 1)->size == it->offset) {
    (it - 1)->size += it->size;
    it = b.freeRanges.erase(it) - 1;
  }
  // An empty block goes back to the driver so a big grid does not pin memory forever.
  if (b.freeRanges.size() == 1 && b.freeRanges[0].size == b.size) {
    d_.vkFreeMemory(device_, b.memory, nullptr);
    b = Block{};
  }
}

}  // namespace blobvk::vk
