// Device loss and device-memory exhaustion, injected into a real device: a vk::Device is built on
// the handles of a validated lavapipe StandaloneContext, but through a getInstanceProcAddr that
// hands out wrappers for vkQueueSubmit / vkAllocateMemory. Failing the k-th call, for every k a
// GPU polygonization reaches, must end in a VulkanError carrying that VkResult: never a crash,
// a hang, a partial mesh or a validation message (leaked or misused objects on error paths).
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/device/standalone.h"
#include "vulkan_required.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <utility>

namespace {

using namespace blobvk;

// The fault plan and the real entry points (one device at a time, so plain globals).
struct Faults {
  int failSubmitAt = -1;    // index of the vkQueueSubmit that reports VK_ERROR_DEVICE_LOST
  int failAllocateAt = -1;  // index of the vkAllocateMemory that reports out of device memory
  int submits = 0, allocations = 0;
  bool lost = false;  // a lost device stays lost: later submits and waits report it too
  PFN_vkGetInstanceProcAddr realGetInstanceProcAddr = nullptr;
  PFN_vkGetDeviceProcAddr realGetDeviceProcAddr = nullptr;
  PFN_vkQueueSubmit realQueueSubmit = nullptr;
  PFN_vkAllocateMemory realAllocateMemory = nullptr;
  PFN_vkWaitForFences realWaitForFences = nullptr;
  PFN_vkDeviceWaitIdle realDeviceWaitIdle = nullptr;
};
Faults g;

void resetFaults() {
  g.failSubmitAt = g.failAllocateAt = -1;
  g.submits = g.allocations = 0;
  g.lost = false;
}

VKAPI_ATTR VkResult VKAPI_CALL queueSubmit(VkQueue queue, std::uint32_t count,
                                           const VkSubmitInfo* submits, VkFence fence) {
  if (g.lost || g.submits++ == g.failSubmitAt) {
    g.lost = true;
    return VK_ERROR_DEVICE_LOST;
  }
  return g.realQueueSubmit(queue, count, submits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL waitForFences(VkDevice device, std::uint32_t count,
                                             const VkFence* fences, VkBool32 all, std::uint64_t timeout) {
  if (g.lost) return VK_ERROR_DEVICE_LOST;
  return g.realWaitForFences(device, count, fences, all, timeout);
}

VKAPI_ATTR VkResult VKAPI_CALL deviceWaitIdle(VkDevice device) {
  if (g.lost) return VK_ERROR_DEVICE_LOST;
  return g.realDeviceWaitIdle(device);
}

VKAPI_ATTR VkResult VKAPI_CALL allocateMemory(VkDevice device, const VkMemoryAllocateInfo* info,
                                              const VkAllocationCallbacks* callbacks,
                                              VkDeviceMemory* memory) {
  if (g.allocations++ == g.failAllocateAt) return VK_ERROR_OUT_OF_DEVICE_MEMORY;
  return g.realAllocateMemory(device, info, callbacks, memory);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL getDeviceProcAddr(VkDevice device, const char* name) {
  if (!std::strcmp(name, "vkQueueSubmit")) return reinterpret_cast<PFN_vkVoidFunction>(queueSubmit);
  if (!std::strcmp(name, "vkWaitForFences")) return reinterpret_cast<PFN_vkVoidFunction>(waitForFences);
  if (!std::strcmp(name, "vkDeviceWaitIdle")) return reinterpret_cast<PFN_vkVoidFunction>(deviceWaitIdle);
  if (!std::strcmp(name, "vkAllocateMemory")) return reinterpret_cast<PFN_vkVoidFunction>(allocateMemory);
  return g.realGetDeviceProcAddr(device, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL getInstanceProcAddr(VkInstance instance, const char* name) {
  if (!std::strcmp(name, "vkGetDeviceProcAddr")) return reinterpret_cast<PFN_vkVoidFunction>(getDeviceProcAddr);
  return g.realGetInstanceProcAddr(instance, name);
}

class FaultInjection : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    setenv("VK_ICD_FILENAMES", "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json", 0);
    setenv("LP_NUM_THREADS", "2", 0);
    if (context_ || !reason_.empty()) return;
    if (!vk::vulkanAvailable(&reason_)) return;
    vk::StandaloneOptions options;
    options.validation = true;
    context_ = std::make_unique<vk::StandaloneContext>(options);
    const vk::HostContext& host = context_->host();
    g.realGetInstanceProcAddr = host.getInstanceProcAddr;
    g.realGetDeviceProcAddr = reinterpret_cast<PFN_vkGetDeviceProcAddr>(
        host.getInstanceProcAddr(host.instance, "vkGetDeviceProcAddr"));
    const auto device = [&](const char* name) { return g.realGetDeviceProcAddr(host.device, name); };
    g.realQueueSubmit = reinterpret_cast<PFN_vkQueueSubmit>(device("vkQueueSubmit"));
    g.realAllocateMemory = reinterpret_cast<PFN_vkAllocateMemory>(device("vkAllocateMemory"));
    g.realWaitForFences = reinterpret_cast<PFN_vkWaitForFences>(device("vkWaitForFences"));
    g.realDeviceWaitIdle = reinterpret_cast<PFN_vkDeviceWaitIdle>(device("vkDeviceWaitIdle"));
  }
  static void TearDownTestSuite() { context_.reset(); }

  void SetUp() override {
    if (!context_) BLOBVK_REQUIRE_VULKAN_OR_SKIP(reason_);
    messagesBefore_ = context_->validationMessages();
  }
  void TearDown() override {
    if (context_) {
      EXPECT_EQ(context_->validationMessages(), messagesBefore_)
          << "Vulkan validation reported problems on an error path (see stderr)";
    }
  }

  // The context's handles, reached through the fault-injecting entry points.
  static vk::HostContext faultyHost() {
    vk::HostContext host = context_->host();
    host.getInstanceProcAddr = getInstanceProcAddr;
    return host;
  }

  // Two blended points: a small job with several bricks, so several submits and allocations.
  static mesh::TriMesh polygonizeBlob(vk::Device& device) {
    const auto [program, grid] = blob();
    vk::GpuPolygonizeOptions options;
    options.maxBrickBytes = 8 * 1024;  // many slabs: many submits to fail at
    return vk::polygonize(device, program, grid, options);
  }

  // A completed job must be the whole mesh: the CPU reference's vertices and triangles.
  static void expectReferenceMesh(const mesh::TriMesh& gpu) {
    const auto [program, grid] = blob();
    const mesh::TriMesh ref = cpu::polygonizeReference(program, grid);
    ASSERT_GT(ref.triangles.size(), 100u);
    EXPECT_EQ(gpu.edgeKeys, ref.edgeKeys);
    EXPECT_EQ(gpu.triangles, ref.triangles);
  }

  static std::pair<blobtree::Program, blobtree::GridSpec> blob() {
    blobtree::Node root;
    root.kind = blobtree::Operator{};
    for (double x : {-0.4, 0.4}) {
      blobtree::Node child;
      blobtree::Primitive p;
      p.a = blobtree::Vec3(x, 0.0, 0.0);
      p.support = 1.0;
      child.kind = p;
      root.children.push_back(child);
    }
    blobtree::Program program = blobtree::compile(root);
    blobtree::GridRequest request;
    request.resolution = 24;
    const blobtree::GridSpec grid = blobtree::chooseGrid(program, {}, request);
    return {std::move(program), grid};
  }

 private:
  static inline std::unique_ptr<vk::StandaloneContext> context_;
  static inline std::string reason_;
  std::uint32_t messagesBefore_ = 0;
};

TEST_F(FaultInjection, WithoutFaultsTheWrappedDeviceWorks) {
  resetFaults();
  vk::Device device(faultyHost());
  const mesh::TriMesh mesh = polygonizeBlob(device);
  expectReferenceMesh(mesh);
  EXPECT_GT(g.submits, 1) << "the job should take several submits for the loss test to mean much";
}

TEST_F(FaultInjection, DeviceLostAtEverySubmitThrowsVulkanError) {
  int failures = 0;
  for (int k = 0; k < 200; ++k) {
    resetFaults();
    g.failSubmitAt = k;
    bool completed = false;
    {
      vk::Device device(faultyHost());  // a lost device is never reused: a fresh one each time
      try {
        expectReferenceMesh(polygonizeBlob(device));  // a job that completes is never partial
        completed = true;
      } catch (const vk::VulkanError& e) {
        ++failures;
        EXPECT_EQ(e.result(), VK_ERROR_DEVICE_LOST) << "submit " << k << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find("lower the resolution"), std::string::npos) << e.what();
      }
    }  // destroying a Device whose device is lost must not throw or crash
    if (completed) {
      EXPECT_LE(g.submits, k) << "finished although submit " << k << " failed";
      break;
    }
  }
  resetFaults();
  EXPECT_GT(failures, 1);
}

TEST_F(FaultInjection, OutOfDeviceMemoryAtEveryAllocationThrowsAndTheDeviceStaysUsable) {
  resetFaults();
  vk::Device device(faultyHost());  // memory exhaustion is transient: the same device is reused
  int failures = 0;
  for (int k = 0; k < 200; ++k) {
    g.failAllocateAt = g.allocations + k;  // counting from this job's first allocation
    const int before = g.allocations;
    bool completed = false;
    try {
      expectReferenceMesh(polygonizeBlob(device));  // a job that completes is never partial
      completed = true;
    } catch (const vk::VulkanError& e) {
      ++failures;
      EXPECT_EQ(e.result(), VK_ERROR_OUT_OF_DEVICE_MEMORY) << "allocation " << k << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find("out of device memory"), std::string::npos) << e.what();
    }
    if (completed) {
      EXPECT_LE(g.allocations - before, k) << "finished although allocation " << k << " failed";
      break;
    }
  }
  g.failAllocateAt = -1;
  EXPECT_GE(failures, 1);
  // After the failures, the same device still produces the full mesh.
  expectReferenceMesh(polygonizeBlob(device));
}

}  // namespace
