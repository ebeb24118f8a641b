// A job's independent kernels are built on several threads at once (vk/device/concurrent_builds.h):
// the kernels come back in the builds' order, the builds really overlap (shown by a rendezvous
// of two builds, not by timing), a failure is reported after every build has ended, and a tiled
// field's kernels land in the Device's cache once each.
#include "blobvk/vk/device/concurrent_builds.h"
#include "blobvk/vk/extract/polygonize.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace blobvk::testing {
namespace {

using Builds = std::vector<std::function<vk::KernelPtr()>>;

TEST(ConcurrentBuilds, TwoBuildsRunAtOnceOnTwoThreads) {
  // Each build waits until the other has started: one after the other, the first would wait out
  // the timeout and see only itself.
  std::mutex m;
  std::condition_variable cv;
  int started = 0;
  std::vector<int> seen;
  auto rendezvous = [&]() -> vk::KernelPtr {
    std::unique_lock lock(m);
    ++started;
    cv.notify_all();
    cv.wait_for(lock, std::chrono::seconds(30), [&] { return started == 2; });
    seen.push_back(started);
    return nullptr;
  };
  const std::uint64_t helpersBefore = vk::concurrentBuildsOnHelpers();
  const Builds builds{rendezvous, rendezvous};
  vk::buildConcurrently(builds, 2);
  EXPECT_EQ(seen, (std::vector<int>{2, 2}));
  EXPECT_EQ(vk::concurrentBuildsOnHelpers() - helpersBefore, 1u);  // one on the caller, one on the helper
}

TEST(ConcurrentBuilds, OneThreadRunsEveryBuildOnTheCaller) {
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<int> elsewhere{0}, runs{0};
  auto build = [&]() -> vk::KernelPtr {
    elsewhere += std::this_thread::get_id() != caller;
    ++runs;
    return nullptr;
  };
  const std::uint64_t helpersBefore = vk::concurrentBuildsOnHelpers();
  vk::buildConcurrently(Builds(5, build), 1);
  EXPECT_EQ(runs.load(), 5);
  EXPECT_EQ(elsewhere.load(), 0);
  EXPECT_EQ(vk::concurrentBuildsOnHelpers(), helpersBefore);
  EXPECT_TRUE(vk::buildConcurrently(Builds{}, 4).empty());
}

TEST(ConcurrentBuilds, TheFirstFailedBuildIsRethrownOnceAllHaveEnded) {
  std::atomic<int> runs{0};
  Builds builds;
  builds.push_back([&]() -> vk::KernelPtr { ++runs; return nullptr; });
  builds.push_back([&]() -> vk::KernelPtr { ++runs; throw std::runtime_error("first failure"); });
  builds.push_back([&]() -> vk::KernelPtr { ++runs; throw std::runtime_error("second failure"); });
  builds.push_back([&]() -> vk::KernelPtr { ++runs; return nullptr; });
  try {
    vk::buildConcurrently(builds, 3);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "first failure");
  }
  EXPECT_EQ(runs.load(), 4);
}

class ConcurrentKernelBuildTest : public VulkanTest {};

TEST_F(ConcurrentKernelBuildTest, KernelsComeBackInTheBuildsOrderAndAreCachedOnce) {
  vk::Device fresh(device().host());  // its own kernel cache
  const std::uint32_t wg[1] = {64};
  const char* names[] = {"scan_reduce", "scan_apply", "brick_row_starts", "scan_reduce", "brick_neighbours"};
  Builds builds;
  for (const char* name : names) builds.push_back([&fresh, &wg, name] { return fresh.kernel(name, wg); });
  const std::vector<vk::KernelPtr> kernels = vk::buildConcurrently(builds, 2);
  ASSERT_EQ(kernels.size(), std::size(names));
  for (std::size_t i = 0; i < kernels.size(); ++i) {
    ASSERT_NE(kernels[i], nullptr) << names[i];
    EXPECT_EQ(kernels[i], fresh.findKernel(names[i], wg)) << names[i];
  }
  EXPECT_EQ(kernels[0], kernels[3]);  // the same kernel asked for twice is one pipeline
  EXPECT_EQ(fresh.cachedKernels(), 4u);
}

TEST_F(ConcurrentKernelBuildTest, TowerFieldTileKernelsAreBuiltOnSeveralThreadsAndKeptOnce) {
  const ShippedScene tower = shipped("tower", 48);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Specialised;
  o.maxFieldTiles = 8;
  vk::Device fresh(device().host());
  const std::uint64_t helpersBefore = vk::concurrentBuildsOnHelpers();
  vk::GpuStats stats;
  const mesh::TriMesh first = vk::polygonize(fresh, tower.program, tower.grid, o, &stats);
  ASSERT_GT(stats.fieldTiles, 1u);
  ASSERT_GT(first.triangleCount(), 0u);
  if (std::thread::hardware_concurrency() > 1) {
    EXPECT_GT(vk::concurrentBuildsOnHelpers(), helpersBefore);
  }
  // A second job finds every kernel built: nothing new in the cache, the same mesh.
  const std::size_t cached = fresh.cachedKernels();
  const mesh::TriMesh second = vk::polygonize(fresh, tower.program, tower.grid, o);
  EXPECT_EQ(fresh.cachedKernels(), cached);
  EXPECT_EQ(first.triangles, second.triangles);
  EXPECT_EQ(first.positions.size(), second.positions.size());
}

}  // namespace
}  // namespace blobvk::testing
