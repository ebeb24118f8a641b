// How blobvk behaves as a guest on a host's device: it never waits on the host's device, its
// pipeline cache is bounded, it keeps no global state, and its uploads can be recorded into the
// host's command buffer instead of blocking submits.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "models.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/memory.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/scan.h"
#include "blobvk/vk/extract/slab_polygonizer.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <future>
#include <numeric>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// The host's own Vulkan calls, through the context's loader.
struct HostCalls {
  explicit HostCalls(const vk::HostContext& h) : host(h) {
    auto gdpa = reinterpret_cast<PFN_vkGetDeviceProcAddr>(h.getInstanceProcAddr(h.instance, "vkGetDeviceProcAddr"));
#define LOAD(name) name = reinterpret_cast<PFN_##name>(gdpa(h.device, #name))
    LOAD(vkCreateCommandPool);
    LOAD(vkDestroyCommandPool);
    LOAD(vkAllocateCommandBuffers);
    LOAD(vkBeginCommandBuffer);
    LOAD(vkEndCommandBuffer);
    LOAD(vkQueueSubmit);
    LOAD(vkCreateFence);
    LOAD(vkDestroyFence);
    LOAD(vkWaitForFences);
    LOAD(vkCreateEvent);
    LOAD(vkDestroyEvent);
    LOAD(vkSetEvent);
    LOAD(vkCmdWaitEvents);
    LOAD(vkCmdPipelineBarrier);
#undef LOAD
  }
  vk::HostContext host;
  PFN_vkCreateCommandPool vkCreateCommandPool;
  PFN_vkDestroyCommandPool vkDestroyCommandPool;
  PFN_vkAllocateCommandBuffers vkAllocateCommandBuffers;
  PFN_vkBeginCommandBuffer vkBeginCommandBuffer;
  PFN_vkEndCommandBuffer vkEndCommandBuffer;
  PFN_vkQueueSubmit vkQueueSubmit;
  PFN_vkCreateFence vkCreateFence;
  PFN_vkDestroyFence vkDestroyFence;
  PFN_vkWaitForFences vkWaitForFences;
  PFN_vkCreateEvent vkCreateEvent;
  PFN_vkDestroyEvent vkDestroyEvent;
  PFN_vkSetEvent vkSetEvent;
  PFN_vkCmdWaitEvents vkCmdWaitEvents;
  PFN_vkCmdPipelineBarrier vkCmdPipelineBarrier;
};

// A command pool, one primary command buffer and a fence the host owns.
struct HostCommands {
  explicit HostCommands(const HostCalls& c) : calls(c) {
    VkCommandPoolCreateInfo pool{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pool.queueFamilyIndex = c.host.queueFamilyIndex;
    c.vkCreateCommandPool(c.host.device, &pool, nullptr, &this->pool);
    VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    alloc.commandPool = this->pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    c.vkAllocateCommandBuffers(c.host.device, &alloc, &cmd);
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    c.vkCreateFence(c.host.device, &fi, nullptr, &fence);
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    c.vkBeginCommandBuffer(cmd, &begin);
  }
  void submit() {
    calls.vkEndCommandBuffer(cmd);
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    ASSERT_EQ(calls.vkQueueSubmit(calls.host.queue, 1, &si, fence), VK_SUCCESS);
  }
  bool wait(std::uint64_t ns = UINT64_MAX) {
    return calls.vkWaitForFences(calls.host.device, 1, &fence, VK_TRUE, ns) == VK_SUCCESS;
  }
  ~HostCommands() {
    calls.vkDestroyFence(calls.host.device, fence, nullptr);
    calls.vkDestroyCommandPool(calls.host.device, pool, nullptr);
  }
  const HostCalls& calls;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
};

// The host has work in flight that only the host can finish (a command buffer waiting for an
// event the host sets later). Destroying a blobvk Device meanwhile must return: a device-wide
// wait (vkDeviceWaitIdle) would block until the host's work ends, here forever.
TEST_F(VulkanTest, DestroyingADeviceNeverWaitsForTheHostsWork) {
  const HostCalls calls(context().host());
  VkEvent event = VK_NULL_HANDLE;
  VkEventCreateInfo ei{VK_STRUCTURE_TYPE_EVENT_CREATE_INFO};
  ASSERT_EQ(calls.vkCreateEvent(calls.host.device, &ei, nullptr, &event), VK_SUCCESS);
  auto blob = std::make_unique<vk::Device>(context().host());
  (void)vk::evaluateFieldOnGrid(*blob, blobtree::compile(testModels()[0].root),
                                blobtree::chooseGrid(blobtree::compile(testModels()[0].root), testBounds(), {}));
  {
    HostCommands host(calls);
    calls.vkCmdWaitEvents(host.cmd, 1, &event, VK_PIPELINE_STAGE_HOST_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                          nullptr, 0, nullptr, 0, nullptr);
    host.submit();
    auto destroyed = std::async(std::launch::async, [&] { blob.reset(); });
    const bool returned = destroyed.wait_for(std::chrono::seconds(20)) == std::future_status::ready;
    calls.vkSetEvent(calls.host.device, event);  // the host finishes its work
    destroyed.wait();
    EXPECT_TRUE(returned) << "~Device waited for the host's queue";
    EXPECT_TRUE(host.wait());
  }
  calls.vkDestroyEvent(calls.host.device, event, nullptr);
}

TEST_F(VulkanTest, ThePipelineCacheEvictsTheLeastRecentlyUsed) {
  vk::DeviceOptions options;
  options.pipelineCacheCapacity = 3;
  vk::Device dev(context().host(), options);
  auto spec = [](std::uint32_t wg) { return std::array<std::uint32_t, 1>{wg}; };
  const auto a = spec(32), b = spec(64), c = spec(128), d = spec(256);
  (void)dev.kernel("scan_reduce", a);
  (void)dev.kernel("scan_reduce", b);
  (void)dev.kernel("scan_reduce", c);
  EXPECT_EQ(dev.cachedKernels(), 3u);
  EXPECT_NE(dev.findKernel("scan_reduce", a), nullptr);  // a is now the most recently used
  (void)dev.kernel("scan_reduce", d);                    // evicts b, the least recently used
  EXPECT_EQ(dev.cachedKernels(), 3u);
  EXPECT_EQ(dev.evictedKernels(), 1u);
  EXPECT_EQ(dev.findKernel("scan_reduce", b), nullptr);
  EXPECT_NE(dev.findKernel("scan_reduce", a), nullptr);
  EXPECT_NE(dev.findKernel("scan_reduce", c), nullptr);
  EXPECT_NE(dev.findKernel("scan_reduce", d), nullptr);
}

// A kernel evicted while still held (a pass, a Recorder) stays valid until released: a scan on a
// one-pipeline cache evicts its reduce kernel when it builds apply, and must still be right.
TEST_F(VulkanTest, AnEvictedKernelStillHeldStaysUsable) {
  vk::DeviceOptions options;
  options.pipelineCacheCapacity = 1;
  vk::Device dev(context().host(), options);
  const std::uint32_t n = 70000;  // several chunks: both kernels run
  std::vector<std::uint32_t> values(n);
  for (std::uint32_t i = 0; i < n; ++i) values[i] = (i * 7u) % 5u;
  vk::Buffer data = dev.createBuffer(n * 4ull), scratch = dev.createBuffer((vk::scanScratchWords(n) + 1) * 4),
             totals = dev.createBuffer(16);
  dev.upload(data, values.data(), n * 4ull);
  dev.run([&](vk::Recorder& rec) {
    vk::recordExclusiveScan(rec, data.handle(), 0, n, scratch.handle(), 0, totals.handle(), 0);
    rec.hostBarrier();
  });
  EXPECT_GE(dev.evictedKernels(), 1u);
  std::vector<std::uint32_t> got(n), expected(n);
  std::exclusive_scan(values.begin(), values.end(), expected.begin(), 0u);
  dev.download(data, got.data(), n * 4ull);
  EXPECT_EQ(got, expected);
}

TEST_F(VulkanTest, TwoDevicesShareNoTilePlans) {
  vk::Device a(context().host()), b(context().host());
  const auto program = blobtree::compile(testModels()[2].root);
  const auto grid = blobtree::chooseGrid(program, testBounds(), {});
  EXPECT_EQ(a.tilePlanCache(), nullptr);
  const auto field = vk::evaluateFieldOnGrid(a, program, grid);
  EXPECT_NE(a.tilePlanCache(), nullptr);
  EXPECT_EQ(b.tilePlanCache(), nullptr) << "a plan made on one Device leaked to another";
  EXPECT_EQ(vk::evaluateFieldOnGrid(b, program, grid), field);
}

// What the Device constructor refuses, each with one VulkanError naming the requirement: an
// instance version not given or below 1.1 (a 1.0 instance may not call the 1.1 commands blobvk
// uses, whatever the device supports), and a device without subgroup vote in compute shaders
// (faked here through the loader: lavapipe has it).
std::string deviceError(const vk::HostContext& host) {
  try {
    vk::Device dev(host);
  } catch (const vk::VulkanError& e) {
    return e.what();
  }
  return "";
}

PFN_vkGetInstanceProcAddr realGipa = nullptr;
PFN_vkGetPhysicalDeviceProperties2 realProperties2 = nullptr;

VKAPI_ATTR void VKAPI_CALL propertiesWithoutVote(VkPhysicalDevice pd, VkPhysicalDeviceProperties2* props) {
  realProperties2(pd, props);
  for (auto* s = static_cast<VkBaseOutStructure*>(props->pNext); s; s = s->pNext)
    if (s->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES)
      reinterpret_cast<VkPhysicalDeviceSubgroupProperties*>(s)->supportedOperations &= ~VK_SUBGROUP_FEATURE_VOTE_BIT;
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL gipaWithoutVote(VkInstance instance, const char* name) {
  if (!std::strcmp(name, "vkGetPhysicalDeviceProperties2"))
    return reinterpret_cast<PFN_vkVoidFunction>(propertiesWithoutVote);
  return realGipa(instance, name);
}

TEST_F(VulkanTest, TheDeviceRefusesAnInstanceOrADeviceItCannotRunOn) {
  vk::HostContext host = context().host();
  ASSERT_EQ(deviceError(host), "");

  vk::HostContext unset = host;
  unset.instanceApiVersion = 0;
  EXPECT_NE(deviceError(unset).find("HostContext.instanceApiVersion is not set"), std::string::npos) << deviceError(unset);

  vk::HostContext old = host;
  old.instanceApiVersion = VK_API_VERSION_1_0;
  EXPECT_NE(deviceError(old).find("created for Vulkan 1.0"), std::string::npos) << deviceError(old);

  vk::HostContext noVote = host;
  realGipa = host.getInstanceProcAddr;
  realProperties2 = reinterpret_cast<PFN_vkGetPhysicalDeviceProperties2>(
      realGipa(host.instance, "vkGetPhysicalDeviceProperties2"));
  noVote.getInstanceProcAddr = gipaWithoutVote;
  EXPECT_NE(deviceError(noVote).find("no subgroup vote operations in compute shaders"), std::string::npos)
      << deviceError(noVote);
}

TEST(StandaloneContext, LeavesTheProcessEnvironmentAlone) {
  setenv("VK_ICD_FILENAMES", "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json", 0);
  unsetenv("LP_NATIVE_VECTOR_WIDTH");
  std::string why;
  ASSERT_TRUE(vk::vulkanAvailable(&why)) << why;
  vk::StandaloneContext context;
  EXPECT_EQ(std::getenv("LP_NATIVE_VECTOR_WIDTH"), nullptr);
}

// The embedding path with uploads recorded into the host's command buffer: on a device whose
// work memory is not mappable (a simulated discrete GPU), the SlabPolygonizer's uploads (its
// Program records and the case table) become copies in the host's command buffer, followed by
// the classify and emit passes, one host submit, no blocking submit of blobvk's own.
TEST_F(VulkanTest, UploadsRecordIntoTheHostsCommandBuffer) {
  vk::MemorySimulation discrete;
  discrete.properties.memoryHeapCount = 2;
  discrete.properties.memoryHeaps[0] = {8ull << 30, VK_MEMORY_HEAP_DEVICE_LOCAL_BIT};
  discrete.properties.memoryHeaps[1] = {16ull << 30, 0};
  discrete.properties.memoryTypeCount = 2;
  discrete.properties.memoryTypes[0] = {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0};
  discrete.properties.memoryTypes[1] = {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                                            VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                                        1};
  vk::DeviceOptions options;
  options.memorySimulation = &discrete;
  vk::Device dev(context().host(), options);
  const HostCalls calls(context().host());

  const auto program = blobtree::compile(testModels()[1].root);
  blobtree::GridRequest request;
  request.resolution = 20;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);
  const auto ref = cpu::polygonizeReference(program, grid, {});

  HostCommands host(calls);
  vk::UploadBatch batch(dev);
  vk::SlabPolygonizer poly(dev, program, grid, {});
  ASSERT_EQ(poly.slabCount(), 1u);
  EXPECT_GE(batch.queuedCopies(), 5u) << "the Program's non-empty record arrays and the case table";
  const vk::SlabPlan plan = poly.plan(0);
  vk::Buffer positions = dev.createBuffer(plan.ownedPoints * 36), normals = dev.createBuffer(plan.ownedPoints * 36),
             colours = dev.createBuffer(plan.ownedPoints * 36), keys = dev.createBuffer(plan.ownedPoints * 12),
             indices = dev.createBuffer(plan.cells * 60);
  {
    batch.record(host.cmd);
    EXPECT_EQ(batch.queuedCopies(), 0u);
    vk::Recorder rec(dev, host.cmd);
    poly.recordClassify(rec, 0, 0, 0);
    poly.recordEmit(rec, 0, 0, {positions, normals, colours, keys, indices, std::uint32_t(3 * plan.ownedPoints),
                                std::uint32_t(5 * plan.cells)});
    rec.hostBarrier();
    host.submit();
    ASSERT_TRUE(host.wait());
  }
  EXPECT_FALSE(poly.readOverflow());
  std::array<std::uint32_t, 7> args{};
  dev.download(poly.drawArgs(), args.data(), sizeof(args));
  ASSERT_EQ(args[5], ref.vertexCount());
  ASSERT_EQ(args[6], ref.triangleCount());
  std::vector<std::uint32_t> gotKeys(args[5]);
  std::vector<mesh::Float3> gotPositions(args[5]);
  std::vector<std::array<std::uint32_t, 3>> gotTriangles(args[6]);
  dev.download(keys, gotKeys.data(), gotKeys.size() * 4);
  dev.download(positions, gotPositions.data(), gotPositions.size() * 12);
  dev.download(indices, gotTriangles.data(), gotTriangles.size() * 12);
  for (std::size_t v = 0; v < gotKeys.size(); ++v) {
    ASSERT_EQ(gotKeys[v], ref.edgeKeys[v]) << v;  // one slab: local keys are global
    EXPECT_NEAR(gotPositions[v].x, ref.positions[v].x, 1e-4f * grid.cellSize + 1e-6f);
    EXPECT_NEAR(gotPositions[v].y, ref.positions[v].y, 1e-4f * grid.cellSize + 1e-6f);
    EXPECT_NEAR(gotPositions[v].z, ref.positions[v].z, 1e-4f * grid.cellSize + 1e-6f);
  }
  for (std::size_t t = 0; t < gotTriangles.size(); ++t) {
    ASSERT_EQ(gotTriangles[t][0], ref.triangles[t][0]) << t;
    ASSERT_EQ(gotTriangles[t][1], ref.triangles[t][1]) << t;
    ASSERT_EQ(gotTriangles[t][2], ref.triangles[t][2]) << t;
  }
}

}  // namespace
}  // namespace blobvk::testing
