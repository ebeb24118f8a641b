// Memory types per use, fallback and budgets (vk/device/memory.h), on layouts of real GPU kinds: the
// ranking as a pure function, then a simulated discrete GPU over lavapipe (MemorySimulation),
// whose meshes must equal the CPU reference and, byte for byte, lavapipe's own.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "models.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/memory.h"
#include "blobvk/vk/extract/polygonize.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace blobvk::testing {
namespace {

using U = std::vector<std::uint32_t>;
constexpr VkMemoryPropertyFlags kLocal = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
constexpr VkMemoryPropertyFlags kHost = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
constexpr VkMemoryPropertyFlags kCached = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
constexpr VkDeviceSize kGiB = 1ull << 30, kMiB = 1ull << 20;

VkPhysicalDeviceMemoryProperties layout(std::vector<std::pair<VkDeviceSize, bool>> heaps,
                                        std::vector<std::pair<VkMemoryPropertyFlags, std::uint32_t>> types) {
  VkPhysicalDeviceMemoryProperties p{};
  p.memoryHeapCount = std::uint32_t(heaps.size());
  for (std::size_t h = 0; h < heaps.size(); ++h) {
    p.memoryHeaps[h] = {heaps[h].first, heaps[h].second ? VkMemoryHeapFlags(VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) : 0u};
  }
  p.memoryTypeCount = std::uint32_t(types.size());
  for (std::size_t t = 0; t < types.size(); ++t) p.memoryTypes[t] = {types[t].first, types[t].second};
  return p;
}

// A discrete GPU without resizable BAR: 8 GiB of VRAM (type 0), system memory (types 1, 2) and
// a 256 MiB window of VRAM the host can map (type 3).
VkPhysicalDeviceMemoryProperties discreteLayout() {
  return layout({{8 * kGiB, true}, {16 * kGiB, false}, {256 * kMiB, true}},
                {{kLocal, 0}, {kHost, 1}, {kHost | kCached, 1}, {kLocal | kHost, 2}});
}

TEST(MemoryTypes, DiscreteGpuKeepsWorkBuffersInVramAndTheBarHeapForLast) {
  const auto p = discreteLayout();
  EXPECT_EQ(vk::rankMemoryTypes(p, 0xf, vk::MemoryUse::DeviceLocal), (U{0, 3, 1, 2}));
  EXPECT_EQ(vk::rankMemoryTypes(p, 0xf, vk::MemoryUse::Upload), (U{1, 2, 3}));
  EXPECT_EQ(vk::rankMemoryTypes(p, 0xf, vk::MemoryUse::Readback), (U{2, 1, 3}));
  // The driver's memoryTypeBits restrict the candidates.
  EXPECT_EQ(vk::rankMemoryTypes(p, 0xe, vk::MemoryUse::DeviceLocal), (U{3, 1, 2}));
  EXPECT_EQ(vk::rankMemoryTypes(p, 0x1, vk::MemoryUse::Readback), U{});
}

TEST(MemoryTypes, ResizableBarAndUnifiedMemoryMapWorkBuffers) {
  // Resizable BAR: the mappable device-local type lives in the big heap.
  const auto rebar = layout({{8 * kGiB, true}, {16 * kGiB, false}},
                            {{kLocal, 0}, {kLocal | kHost, 0}, {kHost, 1}, {kHost | kCached, 1}});
  EXPECT_EQ(vk::rankMemoryTypes(rebar, 0xf, vk::MemoryUse::DeviceLocal), (U{1, 0, 2, 3}));
  EXPECT_EQ(vk::rankMemoryTypes(rebar, 0xf, vk::MemoryUse::Readback), (U{3, 2, 1}));
  EXPECT_EQ(vk::rankMemoryTypes(rebar, 0xf, vk::MemoryUse::Upload), (U{2, 3, 1}));
  // Lavapipe and integrated GPUs: one heap, one type, used for everything.
  const auto uma = layout({{2 * kGiB, true}}, {{kLocal | kHost | kCached, 0}});
  for (auto use : {vk::MemoryUse::DeviceLocal, vk::MemoryUse::Upload, vk::MemoryUse::Readback}) {
    EXPECT_EQ(vk::rankMemoryTypes(uma, 0x1, use), U{0});
  }
}

// A Device on the fixture's VkDevice that sees the discrete layout.
class SimulatedDiscrete : public VulkanTest {
 protected:
  void SetUp() override {
    VulkanTest::SetUp();
    simulation_.properties = discreteLayout();
    simulation_.refuse = [this](std::uint32_t type, VkDeviceSize bytes) {
      attempts_.push_back(type);
      (void)bytes;
      return std::find(refused_.begin(), refused_.end(), type) != refused_.end();
    };
  }
  std::unique_ptr<vk::Device> makeDevice() {
    vk::DeviceOptions options;
    options.memorySimulation = &simulation_;
    return std::make_unique<vk::Device>(context().host(), options);
  }
  vk::MemorySimulation simulation_;
  U attempts_, refused_;
};

TEST_F(SimulatedDiscrete, AFailedAllocationFallsBackToTheNextSuitableType) {
  auto dev = makeDevice();
  {
    vk::Buffer b = dev->createBuffer(4096);
    EXPECT_EQ(b.memoryType(), 0u);
    EXPECT_EQ(b.mapped(), nullptr) << "VRAM without HOST_VISIBLE is never mapped";
  }
  attempts_.clear();
  refused_ = {0};  // VRAM full: the BAR window next
  {
    vk::Buffer b = dev->createBuffer(4096);
    EXPECT_EQ(b.memoryType(), 3u);
    EXPECT_NE(b.mapped(), nullptr);
    EXPECT_EQ(attempts_, (U{0, 3}));
  }
  attempts_.clear();
  refused_ = {0, 3};  // and the window full: system memory
  {
    vk::Buffer b = dev->createBuffer(4096);
    EXPECT_EQ(b.memoryType(), 1u);
    EXPECT_EQ(attempts_, (U{0, 3, 1}));
  }
  attempts_.clear();
  refused_ = {0, 1, 2, 3};
  try {
    (void)dev->createBuffer(4096);
    FAIL() << "expected VulkanError";
  } catch (const vk::VulkanError& e) {
    EXPECT_EQ(e.result(), VK_ERROR_OUT_OF_DEVICE_MEMORY);
    EXPECT_NE(std::string(e.what()).find("out of device memory"), std::string::npos) << e.what();
  }
  EXPECT_EQ(attempts_, (U{0, 3, 1, 2}));
}

// Freed memory is kept and handed to the next allocation of its type and size class: no call
// reaches the driver (here: the simulation's refuse hook, called before every vkAllocateMemory).
TEST_F(SimulatedDiscrete, FreedMemoryIsRetainedAndReusedWithoutANewAllocation) {
  auto dev = makeDevice();
  EXPECT_EQ(dev->memory().retainLimit(), 0u) << "simulated layouts retain nothing unless asked";
  dev->memory().setRetainLimit(256 * kMiB);
  { vk::Buffer b = dev->createBuffer(100 * kMiB); }  // dedicated: 112 MiB, an eighth of 128 MiB
  EXPECT_EQ(attempts_, U{0});
  EXPECT_EQ(dev->memory().retainedBytes(), 112 * kMiB);
  EXPECT_EQ(dev->memory().heapBytes(0), 112 * kMiB);
  attempts_.clear();
  {
    vk::Buffer b = dev->createBuffer(105 * kMiB);  // the same class
    EXPECT_EQ(b.memoryType(), 0u);
    EXPECT_EQ(attempts_, U{}) << "the retained memory was not reused";
    EXPECT_EQ(dev->memory().retainedBytes(), 0u);
  }
  dev->memory().releaseRetained();
  EXPECT_EQ(dev->memory().heapBytes(0), 0u);
  // Over the limit nothing is kept.
  dev->memory().setRetainLimit(100 * kMiB);
  { vk::Buffer b = dev->createBuffer(100 * kMiB); }
  EXPECT_EQ(dev->memory().retainedBytes(), 0u);
  EXPECT_EQ(dev->memory().heapBytes(0), 0u);
}

// A discrete GPU's own memory (its BAR window too) and the host's memory are retained under
// their own limits: the device's pool keeps what the host's may not.
TEST_F(SimulatedDiscrete, DeviceAndHostMemoryHaveTheirOwnRetainLimits) {
  auto dev = makeDevice();
  dev->memory().setRetainLimits(0, 256 * kMiB);
  EXPECT_EQ(dev->memory().retainLimit(), 0u);
  EXPECT_EQ(dev->memory().deviceRetainLimit(), 256 * kMiB);
  {
    vk::Buffer work = dev->createBuffer(100 * kMiB);
    vk::Buffer readback = dev->createBuffer(100 * kMiB, vk::MemoryUse::Readback);
    EXPECT_EQ(work.memoryType(), 0u);
    EXPECT_NE(readback.memoryType(), 0u);
  }
  EXPECT_EQ(dev->memory().retainedBytes(), 112 * kMiB) << "only the VRAM buffer is kept";
  EXPECT_EQ(dev->memory().heapBytes(1), 0u) << "the pinned host memory went back";
  attempts_.clear();
  { vk::Buffer again = dev->createBuffer(100 * kMiB); }
  EXPECT_EQ(attempts_, U{}) << "the VRAM was reused";
  // Lowering the device's limit frees what is past it.
  dev->memory().setRetainLimits(0, 64 * kMiB);
  EXPECT_EQ(dev->memory().retainedBytes(), 0u);
  EXPECT_EQ(dev->memory().heapBytes(0), 0u);
  // The BAR window (host-visible, device-local) is the device's memory too.
  dev->memory().setRetainLimits(0, 256 * kMiB);
  refused_ = {0};
  {
    vk::Buffer bar = dev->createBuffer(40 * kMiB);
    EXPECT_EQ(bar.memoryType(), 3u);
  }
  EXPECT_EQ(dev->memory().retainedBytes(), 40 * kMiB);
}

// Retained memory never makes an allocation fail: it is given back first.
TEST_F(SimulatedDiscrete, RetainedMemoryIsGivenBackBeforeAnAllocationFails) {
  simulation_.heapBudget = {120 * kMiB, 16 * kGiB, 256 * kMiB};
  auto dev = makeDevice();
  dev->memory().setRetainLimit(kGiB);
  { vk::Buffer b = dev->createBuffer(80 * kMiB); }  // 80 MiB kept
  EXPECT_EQ(dev->memory().heapBytes(0), 80 * kMiB);
  vk::Buffer b = dev->createBuffer(60 * kMiB);  // class 64 MiB: 80 + 64 would pass 120 MiB
  EXPECT_EQ(b.memoryType(), 0u) << "VRAM, after giving the retained memory back";
  EXPECT_EQ(dev->memory().retainedBytes(), 0u);
  EXPECT_EQ(dev->memory().heapBytes(0), 64 * kMiB);
}

TEST_F(SimulatedDiscrete, AHeapAtItsBudgetIsSkipped) {
  // As VK_EXT_memory_budget would report: the BAR window has 1 MiB left to this process.
  simulation_.heapBudget = {8 * kGiB, 16 * kGiB, 1 * kMiB};
  refused_ = {0};
  auto dev = makeDevice();
  vk::Buffer b = dev->createBuffer(4096);
  EXPECT_EQ(b.memoryType(), 1u);
  EXPECT_EQ(attempts_, (U{0, 1})) << "type 3's block (32 MiB) would pass its heap's budget: never tried";
  EXPECT_EQ(dev->memory().heapBytes(2), 0u);
  // A small heap gets small blocks: an eighth of 256 MiB, not the usual 64 MiB.
  simulation_.heapBudget.clear();
  auto dev2 = makeDevice();
  vk::Buffer c = dev2->createBuffer(4096);
  EXPECT_EQ(c.memoryType(), 3u);
  EXPECT_EQ(dev2->memory().heapBytes(2), 32 * kMiB);
}

// Every upload and read-back through staging (VRAM is not mappable), or (refusing VRAM) work
// buffers in uncached BAR memory that downloads must not read directly: the mesh must not change.
TEST_F(SimulatedDiscrete, MeshesEqualTheCpuReferenceAndLavapipesOwn) {
  const auto model = testModels()[1];
  const auto program = blobtree::compile(model.root);
  blobtree::GridRequest request;
  request.resolution = 20;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);
  const auto ref = cpu::polygonizeReference(program, grid, {});
  const auto native = vk::polygonize(device(), program, grid);
  ASSERT_GT(ref.triangleCount(), 0u);

  for (const U& refuse : {U{}, U{0}}) {
    refused_ = refuse;
    attempts_.clear();
    auto dev = makeDevice();
    const auto gpu = vk::polygonize(*dev, program, grid);
    EXPECT_EQ(gpu.edgeKeys, ref.edgeKeys);
    EXPECT_EQ(gpu.triangles, ref.triangles);
    ASSERT_EQ(gpu.positions.size(), ref.positions.size());
    float worst = 0;
    for (std::size_t v = 0; v < ref.positions.size(); ++v) {
      worst = std::max({worst, std::abs(gpu.positions[v].x - ref.positions[v].x),
                        std::abs(gpu.positions[v].y - ref.positions[v].y),
                        std::abs(gpu.positions[v].z - ref.positions[v].z)});
    }
    EXPECT_LT(worst, 1e-4f * grid.cellSize + 1e-6f);
    // The same kernels on the same device: only where the bytes lived changed.
    EXPECT_EQ(0, std::memcmp(gpu.positions.data(), native.positions.data(), native.positions.size() * 12));
    EXPECT_EQ(0, std::memcmp(gpu.normals.data(), native.normals.data(), native.normals.size() * 12));
    EXPECT_EQ(gpu.colours.size(), native.colours.size());
    // Read-backs through cached system memory (type 2); uploads to unmappable VRAM staged in
    // uncached system memory (type 1), to the BAR window written directly.
    const auto tried = [&](std::uint32_t t) { return std::find(attempts_.begin(), attempts_.end(), t) != attempts_.end(); };
    EXPECT_TRUE(tried(2));
    EXPECT_EQ(tried(1), refuse.empty());
  }
}

// VK_EXT_memory_budget on a device that reports it: the device's entry points are wrapped (as an
// engine's loader could) so that lavapipe advertises the extension and reports a budget the test
// sets; the allocator must ask for it and keep within it.
struct FakeBudget {
  PFN_vkGetInstanceProcAddr real = nullptr;
  PFN_vkEnumerateDeviceExtensionProperties realExtensions = nullptr;
  PFN_vkGetPhysicalDeviceMemoryProperties2 realProperties2 = nullptr;
  VkDeviceSize budget = 0, usage = 0;
  int queries = 0;
};
FakeBudget fake;

VKAPI_ATTR VkResult VKAPI_CALL fakeExtensions(VkPhysicalDevice pd, const char* layer, std::uint32_t* count,
                                              VkExtensionProperties* out) {
  std::uint32_t n = 0;
  fake.realExtensions(pd, layer, &n, nullptr);
  std::vector<VkExtensionProperties> all(n);
  fake.realExtensions(pd, layer, &n, all.data());
  VkExtensionProperties budget{};
  std::strcpy(budget.extensionName, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME);
  budget.specVersion = 1;
  all.push_back(budget);
  if (!out) {
    *count = std::uint32_t(all.size());
    return VK_SUCCESS;
  }
  const std::uint32_t written = std::min<std::uint32_t>(*count, std::uint32_t(all.size()));
  std::copy(all.begin(), all.begin() + written, out);
  *count = written;
  return written < all.size() ? VK_INCOMPLETE : VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL fakeProperties2(VkPhysicalDevice pd, VkPhysicalDeviceMemoryProperties2* props) {
  // The real driver gets a chain without the budget structure it does not know.
  VkPhysicalDeviceMemoryProperties2 plain{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2};
  fake.realProperties2(pd, &plain);
  props->memoryProperties = plain.memoryProperties;
  for (auto* s = static_cast<VkBaseOutStructure*>(props->pNext); s; s = s->pNext) {
    if (s->sType != VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT) continue;
    auto* b = reinterpret_cast<VkPhysicalDeviceMemoryBudgetPropertiesEXT*>(s);
    for (std::uint32_t h = 0; h < VK_MAX_MEMORY_HEAPS; ++h) {
      b->heapBudget[h] = fake.budget;
      b->heapUsage[h] = fake.usage;
    }
    ++fake.queries;
  }
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL fakeGetInstanceProcAddr(VkInstance instance, const char* name) {
  if (!std::strcmp(name, "vkEnumerateDeviceExtensionProperties")) {
    return reinterpret_cast<PFN_vkVoidFunction>(fakeExtensions);
  }
  if (!std::strcmp(name, "vkGetPhysicalDeviceMemoryProperties2")) {
    return reinterpret_cast<PFN_vkVoidFunction>(fakeProperties2);
  }
  return fake.real(instance, name);
}

TEST_F(VulkanTest, TheMemoryBudgetExtensionIsRespectedWhenPresent) {
  vk::HostContext host = context().host();
  fake.real = host.getInstanceProcAddr;
  fake.realExtensions = reinterpret_cast<PFN_vkEnumerateDeviceExtensionProperties>(
      fake.real(host.instance, "vkEnumerateDeviceExtensionProperties"));
  fake.realProperties2 = reinterpret_cast<PFN_vkGetPhysicalDeviceMemoryProperties2>(
      fake.real(host.instance, "vkGetPhysicalDeviceMemoryProperties2"));
  host.getInstanceProcAddr = fakeGetInstanceProcAddr;
  vk::Device dev(host);
  ASSERT_TRUE(dev.memory().hasBudgetExtension());

  // 100 MiB budget, 90 MiB of it used by the rest of the process: a 64 MiB block does not fit.
  fake.budget = 100 * kMiB;
  fake.usage = 90 * kMiB;
  fake.queries = 0;
  try {
    (void)dev.createBuffer(4096);
    FAIL() << "expected VulkanError: the only memory type's heap is at its budget";
  } catch (const vk::VulkanError& e) {
    EXPECT_EQ(e.result(), VK_ERROR_OUT_OF_DEVICE_MEMORY) << e.what();
  }
  EXPECT_GT(fake.queries, 0) << "the budget was never asked for";
  EXPECT_EQ(dev.memory().heapBytes(0), 0u);

  fake.usage = 0;  // the rest of the process freed its memory: the same request succeeds
  vk::Buffer b = dev.createBuffer(4096);
  EXPECT_EQ(dev.memory().heapBytes(0), 64 * kMiB);
  // Within the budget the block is used; the heap's size is no longer the limit.
  fake.budget = 65 * kMiB;
  fake.usage = 64 * kMiB;  // the block just made
  vk::Buffer c = dev.createBuffer(1 * kMiB);  // fits in the block: no new memory
  EXPECT_EQ(dev.memory().heapBytes(0), 64 * kMiB);
  EXPECT_THROW((void)dev.createBuffer(48 * kMiB), vk::VulkanError) << "a dedicated 48 MiB is over the budget";
}

}  // namespace
}  // namespace blobvk::testing
