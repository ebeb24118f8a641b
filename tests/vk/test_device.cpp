#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/shader_registry.h"
#include "blobvk/vk/device/standalone.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace blobvk::testing {
namespace {

class DeviceTest : public VulkanTest {};

TEST_F(DeviceTest, ListsTheDeviceTheContextUses) {
  const auto devices = vk::listDevices();
  ASSERT_FALSE(devices.empty());
  const bool found = std::any_of(devices.begin(), devices.end(), [&](const vk::DeviceInfo& d) {
    return d.name == device().info().name;
  });
  EXPECT_TRUE(found);
  EXPECT_GE(device().info().limits.maxStorageBufferRange, 1u << 20);
  EXPECT_GE(VK_API_VERSION_MINOR(device().info().apiVersion), 1u);
}

TEST_F(DeviceTest, UnknownDeviceNameIsAClearError) {
  vk::StandaloneOptions options;
  options.device = "no-such-gpu-xyz";
  try {
    vk::StandaloneContext ctx(options);
    FAIL() << "expected VulkanError";
  } catch (const vk::VulkanError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-gpu-xyz"), std::string::npos);
  }
}

TEST_F(DeviceTest, EveryShaderIsEmbeddedAsSpirv) {
  const auto names = vk::shaderNames();
  EXPECT_GE(names.size(), 8u);
  for (auto n : names) {
    const auto code = vk::shaderCode(n);
    ASSERT_GT(code.size(), 5u) << n;
    EXPECT_EQ(code[0], 0x07230203u) << n;  // SPIR-V magic
  }
  EXPECT_THROW(vk::shaderCode("missing"), vk::VulkanError);
}

TEST_F(DeviceTest, AllocatorReusesFreedSpaceAndUploadsRoundTrip) {
  std::vector<std::uint32_t> data(5000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = std::uint32_t(i * 2654435761u);
  const auto before = device().memory().bytesInUse();
  {
    std::vector<vk::Buffer> buffers;
    for (int i = 0; i < 20; ++i) buffers.push_back(device().createBuffer(data.size() * 4));
    for (auto& b : buffers) device().upload(b, data.data(), data.size() * 4);
    std::vector<std::uint32_t> back(data.size());
    device().download(buffers[7], back.data(), back.size() * 4);
    EXPECT_EQ(back, data);
    EXPECT_GT(device().memory().bytesInUse(), before);
  }
  EXPECT_EQ(device().memory().bytesInUse(), before);
}

// Host work between a submit and its wait runs once, before the results are read; when it
// throws, the submit's commands have finished before the exception reaches the caller (whose
// buffers they use), and the device takes the next submit.
TEST_F(DeviceTest, HostWorkWhileTheDeviceRunsAndItsExceptions) {
  vk::Buffer b = device().createBuffer(1 << 20);
  int calls = 0;
  device().run([&](vk::Recorder& rec) {
    rec.fill(b, 7u);
    rec.hostBarrier();
  }, [&] { ++calls; });
  EXPECT_EQ(calls, 1);
  std::vector<std::uint32_t> back(4);
  device().download(b, back.data(), 16);
  EXPECT_EQ(back, std::vector<std::uint32_t>(4, 7u));
  EXPECT_THROW(device().run([&](vk::Recorder& rec) {
    rec.fill(b, 9u);
    rec.hostBarrier();
  }, [] { throw std::runtime_error("host work failed"); }),
               std::runtime_error);
  device().download(b, back.data(), 16);
  EXPECT_EQ(back, std::vector<std::uint32_t>(4, 9u)) << "the fill ran to its end";
  device().run([&](vk::Recorder& rec) {
    rec.fill(b, 11u);
    rec.hostBarrier();
  });
  device().download(b, back.data(), 16);
  EXPECT_EQ(back, std::vector<std::uint32_t>(4, 11u));
}

TEST_F(DeviceTest, StagingPathRoundTrips) {
  device().setForceStaging(true);
  std::vector<float> data(1000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = float(i) * 0.25f;
  vk::Buffer b = device().createBuffer(data.size() * 4);
  EXPECT_EQ(b.mapped(), nullptr);
  device().upload(b, data.data(), data.size() * 4);
  std::vector<float> back(data.size());
  device().download(b, back.data(), back.size() * 4);
  device().setForceStaging(false);
  EXPECT_EQ(back, data);
}

// The fixture's zero-message bar only means something if the layer catches hazards: a dispatch
// reading what the previous one wrote, with no barrier between them, must be reported (as a sync
// hazard), and the same pair with the barrier must not. A context of its own, so the expected
// message does not fail the shared fixture's check.
TEST_F(DeviceTest, SynchronisationValidationReportsAMissingBarrier) {
  vk::StandaloneOptions options;
  options.validation = true;
  options.printValidationMessages = false;
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  vk::StandaloneContext ctx(options);
  vk::Device& dev = ctx.device();
  const std::vector<std::uint32_t> ones(256, 1u);
  vk::Buffer values = dev.createBuffer(ones.size() * 4), sums = dev.createBuffer(64), totals = dev.createBuffer(16);
  const std::uint32_t spec[1] = {64};
  // The scan's two passes: chunk sums, then each chunk scanned from its (here unscanned) sum.
  const vk::KernelPtr reduce = dev.kernel("scan_reduce", spec);
  const vk::KernelPtr apply = dev.kernel("scan_apply", spec);
  const std::uint32_t reducePush[3] = {0u, std::uint32_t(ones.size()), 0u};
  const std::uint32_t applyPush[5] = {0u, std::uint32_t(ones.size()), 0u, 1u, ~0u};
  const vk::BufferRange reduceBind[2] = {values, sums}, applyBind[3] = {values, sums, totals};
  auto writeThenRead = [&](bool barrier) {
    dev.upload(values, ones.data(), ones.size() * 4);
    dev.run([&](vk::Recorder& rec) {
      rec.dispatch(*reduce, reduceBind, reducePush, sizeof(reducePush), 1);
      if (barrier) rec.computeBarrier();
      rec.dispatch(*apply, applyBind, applyPush, sizeof(applyPush), 1);
      rec.hostBarrier();
    });
  };
  writeThenRead(true);
  ASSERT_EQ(ctx.validationMessages(), 0u) << ctx.lastValidationMessageId();
  std::vector<std::uint32_t> back(ones.size());
  dev.download(values, back.data(), back.size() * 4);
  EXPECT_EQ(back[70], 64u + 6u);  // chunk 1 starts from its chunk's sum (64), then 6 ones
  writeThenRead(false);
  EXPECT_GE(ctx.validationMessages(), 1u);
  EXPECT_EQ(ctx.lastValidationMessageId().rfind("SYNC-HAZARD-", 0), 0u) << ctx.lastValidationMessageId();
}

// A pass builds its slowest kernel on a thread of its own while it builds the others
// (vk/extract/sparse_batches.cpp): kernels asked for from several threads at once come back as
// one pipeline per name, cached once, and run.
TEST_F(DeviceTest, KernelsBuiltOnSeveralThreadsAtOnceAreKeptOnce) {
  vk::StandaloneOptions options;
  options.validation = true;
  options.pipelineCache = "off";
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  vk::StandaloneContext ctx(options);
  vk::Device& dev = ctx.device();
  const std::size_t before = dev.cachedKernels();
  constexpr int kThreads = 4;
  const std::uint32_t spec[1] = {64};
  std::vector<vk::KernelPtr> reduce(kThreads), apply(kThreads);
  {
    std::vector<std::jthread> threads;
    for (int t = 0; t < kThreads; ++t)
      threads.emplace_back([&, t] {
        reduce[t] = dev.kernel("scan_reduce", spec);
        apply[t] = dev.kernel("scan_apply", spec);
      });
  }
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_TRUE(reduce[t] && apply[t]);
    EXPECT_EQ(reduce[t], reduce[0]);
    EXPECT_EQ(apply[t], apply[0]);
  }
  EXPECT_NE(reduce[0], apply[0]);
  EXPECT_EQ(dev.cachedKernels(), before + 2);
  // The cached pipelines work: a scan of ones gives each element its index.
  const std::vector<std::uint32_t> ones(256, 1u);
  vk::Buffer values = dev.createBuffer(ones.size() * 4), sums = dev.createBuffer(64), totals = dev.createBuffer(16);
  dev.upload(values, ones.data(), ones.size() * 4);
  const std::uint32_t reducePush[3] = {0u, std::uint32_t(ones.size()), 0u};
  const std::uint32_t applyPush[5] = {0u, std::uint32_t(ones.size()), 0u, 1u, ~0u};
  const vk::BufferRange reduceBind[2] = {values, sums}, applyBind[3] = {values, sums, totals};
  dev.run([&](vk::Recorder& rec) {
    rec.dispatch(*dev.kernel("scan_reduce", spec), reduceBind, reducePush, sizeof(reducePush), 1);
    rec.computeBarrier();
    rec.dispatch(*dev.kernel("scan_apply", spec), applyBind, applyPush, sizeof(applyPush), 1);
    rec.hostBarrier();
  });
  std::vector<std::uint32_t> back(ones.size());
  dev.download(values, back.data(), back.size() * 4);
  EXPECT_EQ(back[70], 64u + 6u);  // as SynchronisationValidationReportsAMissingBarrier's scan
  EXPECT_EQ(ctx.validationMessages(), 0u) << ctx.lastValidationMessageId();
}

}  // namespace
}  // namespace blobvk::testing
