#include "blobvk/vk/device/memory.h"

#include "blobvk/vk/device/error.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <tuple>

namespace blobvk::vk {
namespace {
VkDeviceSize alignUp(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

// Dedicated allocations are rounded up to an eighth of their power of two (at most 12.5 % more),
// so that jobs of nearly the same size reuse each other's retained memory.
VkDeviceSize sizeClass(VkDeviceSize size) {
  const VkDeviceSize pow2 = std::bit_ceil(size);
  return alignUp(size, std::max<VkDeviceSize>(pow2 / 8, 64 << 10));
}
constexpr VkMemoryPropertyFlags kHostFlags =
    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;

bool hasFlags(VkMemoryPropertyFlags f, VkMemoryPropertyFlags want) { return (f & want) == want; }

bool deviceHasExtension(const Dispatch& d, VkPhysicalDevice physical, const char* name) {
  std::uint32_t n = 0;
  if (d.vkEnumerateDeviceExtensionProperties(physical, nullptr, &n, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> extensions(n);
  if (d.vkEnumerateDeviceExtensionProperties(physical, nullptr, &n, extensions.data()) < 0) return false;
  return std::any_of(extensions.begin(), extensions.begin() + n,
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}
}  // namespace

std::vector<std::uint32_t> rankMemoryTypes(const VkPhysicalDeviceMemoryProperties& props,
                                           std::uint32_t typeBits, MemoryUse use) {
  // The largest device-local heap: the GPU's own memory (a BAR window is a smaller heap; with
  // resizable BAR or unified memory the mappable type lives in this heap too).
  std::uint32_t mainHeap = ~0u;
  for (std::uint32_t h = 0; h < props.memoryHeapCount; ++h) {
    if (!(props.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)) continue;
    if (mainHeap == ~0u || props.memoryHeaps[h].size > props.memoryHeaps[mainHeap].size) mainHeap = h;
  }
  using Rank = std::tuple<int, int, int, std::uint32_t>;  // smaller is better; index breaks ties
  std::vector<Rank> ranks;
  for (std::uint32_t i = 0; i < props.memoryTypeCount; ++i) {
    if (!(typeBits & (1u << i))) continue;
    const auto f = props.memoryTypes[i].propertyFlags;
    const bool local = f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    const bool host = hasFlags(f, kHostFlags);
    const bool cached = f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    switch (use) {
      case MemoryUse::DeviceLocal: {
        const int tier = !local ? 2 : props.memoryTypes[i].heapIndex == mainHeap ? 0 : 1;
        ranks.emplace_back(tier, host ? 0 : 1, cached ? 1 : 0, i);  // write-combined for GPU data
        break;
      }
      case MemoryUse::Upload:
        if (host) ranks.emplace_back(local ? 1 : 0, cached ? 1 : 0, 0, i);
        break;
      case MemoryUse::Readback:
        if (host) ranks.emplace_back(cached ? 0 : 1, local ? 1 : 0, 0, i);
        break;
    }
  }
  std::sort(ranks.begin(), ranks.end());
  std::vector<std::uint32_t> order;
  for (const auto& r : ranks) order.push_back(std::get<3>(r));
  return order;
}

MemoryAllocator::MemoryAllocator(const Dispatch& d, VkPhysicalDevice physical, VkDevice device,
                                 VkDeviceSize blockSize, const MemorySimulation* simulation)
    : d_(d), physical_(physical), device_(device), blockSize_(blockSize) {
  if (simulation) {
    simulation_ = std::make_unique<MemorySimulation>(*simulation);
    props_ = simulation->properties;
    // Simulated host-visible types are mapped, so they must land on a real type that can be: on a
    // discrete GPU the real type 0 is usually DEVICE_LOCAL only (vkMapMemory would fail there).
    if (simulation_->realType == kAnyMappableRealType) {
      VkPhysicalDeviceMemoryProperties real{};
      d_.vkGetPhysicalDeviceMemoryProperties(physical, &real);
      simulation_->realType = 0;
      for (std::uint32_t i = 0; i < real.memoryTypeCount; ++i) {
        if (hasFlags(real.memoryTypes[i].propertyFlags,
                     VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)) {
          simulation_->realType = i;
          break;
        }
      }
    }
  } else {
    d_.vkGetPhysicalDeviceMemoryProperties(physical, &props_);
    // Physical-device queries of a device extension need only the device to support it (1.1).
    budgetExtension_ = deviceHasExtension(d_, physical, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME);
  }
  // A device with a heap that is not device-local keeps the host's memory there, so its
  // device-local heaps are its own memory; where every heap is device-local (lavapipe, most
  // integrated GPUs) they are the host's (retainPool).
  for (std::uint32_t h = 0; h < props_.memoryHeapCount; ++h)
    separateHostHeap_ |= !(props_.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT);
}

MemoryAllocator::~MemoryAllocator() {
  for (auto& b : blocks_) {
    if (b.memory) d_.vkFreeMemory(device_, b.memory, nullptr);
  }
  for (const Retained& r : retained_) d_.vkFreeMemory(device_, r.memory, nullptr);
}

int MemoryAllocator::retainPool(std::uint32_t type) const {
  const bool localHeap = props_.memoryHeaps[props_.memoryTypes[type].heapIndex].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT;
  return separateHostHeap_ && localHeap ? 1 : 0;
}

void MemoryAllocator::setRetainLimits(VkDeviceSize hostBytes, VkDeviceSize deviceBytes) {
  retainLimit_ = {hostBytes, deviceBytes};
  // Oldest first out of each pool past its limit.
  for (auto it = retained_.begin(); it != retained_.end();) {
    const int pool = retainPool(it->type);
    if (retainedBytes_[pool] <= retainLimit_[pool]) {
      ++it;
      continue;
    }
    retainedBytes_[pool] -= it->size;
    freeMemory(it->type, it->size, it->memory);
    it = retained_.erase(it);
  }
}

void MemoryAllocator::releaseRetained() {
  const auto limits = retainLimit_;
  setRetainLimits(0, 0);
  retainLimit_ = limits;
}

VkDeviceMemory MemoryAllocator::reuseRetained(std::uint32_t type, VkDeviceSize size, void** mapped) {
  // Newest first: the memory the last job freed is the likeliest to be asked for again.
  for (auto it = retained_.rbegin(); it != retained_.rend(); ++it) {
    if (it->type != type || it->size != size) continue;
    const Retained r = *it;
    retained_.erase(std::next(it).base());
    retainedBytes_[retainPool(type)] -= r.size;
    *mapped = r.mapped;
    return r.memory;
  }
  return VK_NULL_HANDLE;
}

std::size_t MemoryAllocator::blockCount() const {
  return std::size_t(std::count_if(blocks_.begin(), blocks_.end(),
                                   [](const Block& b) { return b.memory != VK_NULL_HANDLE; }));
}

bool MemoryAllocator::withinBudget(std::uint32_t type, VkDeviceSize bytes) const {
  const std::uint32_t heap = props_.memoryTypes[type].heapIndex;
  if (budgetExtension_) {
    VkPhysicalDeviceMemoryBudgetPropertiesEXT budget{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT};
    VkPhysicalDeviceMemoryProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2};
    props.pNext = &budget;
    d_.vkGetPhysicalDeviceMemoryProperties2(physical_, &props);
    return budget.heapUsage[heap] + bytes <= budget.heapBudget[heap];
  }
  VkDeviceSize limit = props_.memoryHeaps[heap].size;
  if (simulation_ && heap < simulation_->heapBudget.size()) limit = simulation_->heapBudget[heap];
  return heapBytes_[heap] + bytes <= limit;
}

VkDeviceSize MemoryAllocator::blockSizeFor(std::uint32_t type) const {
  // Small heaps (a 256 MiB BAR window) get blocks of an eighth of the heap, so one block does not
  // take a quarter of it.
  const VkDeviceSize heap = props_.memoryHeaps[props_.memoryTypes[type].heapIndex].size;
  return std::max<VkDeviceSize>(1ull << 20, std::min(blockSize_, heap / 8));
}

VkDeviceMemory MemoryAllocator::allocateMemory(std::uint32_t type, VkDeviceSize size, void** mapped) {
  *mapped = nullptr;
  if (VkDeviceMemory reused = reuseRetained(type, size, mapped)) return reused;
  auto attempt = [&]() -> VkDeviceMemory {
    if (!withinBudget(type, size)) return VK_NULL_HANDLE;
    if (simulation_ && simulation_->refuse && simulation_->refuse(type, size)) return VK_NULL_HANDLE;
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = size;
    info.memoryTypeIndex = simulation_ ? simulation_->realType : type;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    const VkResult r = d_.vkAllocateMemory(device_, &info, nullptr, &memory);
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY) return VK_NULL_HANDLE;  // the next type may have room
    check(r, "vkAllocateMemory");
    return memory;
  };
  VkDeviceMemory memory = attempt();
  if (!memory && !retained_.empty()) {  // memory kept for reuse must never make an allocation fail
    releaseRetained();
    memory = attempt();
  }
  if (!memory) return VK_NULL_HANDLE;
  if (hasFlags(props_.memoryTypes[type].propertyFlags, kHostFlags)) {
    const VkResult m = d_.vkMapMemory(device_, memory, 0, VK_WHOLE_SIZE, 0, mapped);
    if (m < 0) {
      d_.vkFreeMemory(device_, memory, nullptr);
      check(m, "vkMapMemory");
    }
  }
  heapBytes_[props_.memoryTypes[type].heapIndex] += size;
  return memory;
}

void MemoryAllocator::releaseMemory(std::uint32_t type, VkDeviceSize size, VkDeviceMemory memory, void* mapped) {
  const int pool = retainPool(type);
  if (size > retainLimit_[pool]) {
    freeMemory(type, size, memory);
    return;
  }
  retained_.push_back({memory, type, size, mapped});
  retainedBytes_[pool] += size;
  setRetainLimits(retainLimit_[0], retainLimit_[1]);  // oldest out past the limit
}

void MemoryAllocator::freeMemory(std::uint32_t type, VkDeviceSize size, VkDeviceMemory memory) {
  d_.vkFreeMemory(device_, memory, nullptr);
  heapBytes_[props_.memoryTypes[type].heapIndex] -= size;
}

bool MemoryAllocator::allocateInBlocks(const VkMemoryRequirements& req, std::uint32_t type, Allocation& a) {
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
    if (tryBlock(bi)) return true;
  }
  Block nb;
  nb.type = type;
  nb.size = blockSizeFor(type);
  nb.memory = allocateMemory(type, nb.size, &nb.mapped);
  if (!nb.memory) return false;
  nb.freeRanges.push_back({0, nb.size});
  std::uint32_t slot = 0;
  while (slot < blocks_.size() && blocks_[slot].memory) ++slot;
  if (slot == blocks_.size()) blocks_.push_back(std::move(nb));
  else blocks_[slot] = std::move(nb);
  return tryBlock(slot);
}

Allocation MemoryAllocator::allocate(const VkMemoryRequirements& req, MemoryUse use) {
  std::uint32_t typeBits = req.memoryTypeBits;
  // Under a simulation the driver's type bits name real types: every simulated type stands in
  // for the real one.
  if (simulation_) {
    typeBits = (req.memoryTypeBits >> simulation_->realType) & 1u ? (1u << props_.memoryTypeCount) - 1 : 0u;
  }
  const std::vector<std::uint32_t> candidates = rankMemoryTypes(props_, typeBits, use);
  if (candidates.empty()) {
    throw VulkanError("no Vulkan memory type fits a buffer (the driver reports none host visible and coherent)");
  }
  for (const std::uint32_t type : candidates) {
    Allocation a;
    a.size = req.size;
    a.type = type;
    const auto flags = props_.memoryTypes[type].propertyFlags;
    a.hostCached = hasFlags(flags, kHostFlags | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
    bool ok = false;
    if (req.size > blockSizeFor(type) / 2) {  // dedicated: big grids get their own memory
      a.memorySize = sizeClass(req.size);
      a.memory = allocateMemory(type, a.memorySize, &a.mapped);
      ok = a.memory != VK_NULL_HANDLE;
    } else {
      ok = allocateInBlocks(req, type, a);
    }
    if (ok) {
      inUse_ += req.size;
      return a;
    }
  }
  throwVulkanError(VK_ERROR_OUT_OF_DEVICE_MEMORY,
                   ("vkAllocateMemory of " + std::to_string(req.size) + " bytes in every suitable memory type").c_str());
}

void MemoryAllocator::free(const Allocation& a) {
  if (!a.memory) return;
  inUse_ -= a.size;
  if (a.block == ~0u) {
    releaseMemory(a.type, a.memorySize, a.memory, a.mapped);
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
  // An empty block goes back to the driver (or to the retained memory) so a big grid does not
  // pin memory forever.
  if (b.freeRanges.size() == 1 && b.freeRanges[0].size == b.size) {
    releaseMemory(b.type, b.size, b.memory, b.mapped);
    b = Block{};
  }
}

}  // namespace blobvk::vk
