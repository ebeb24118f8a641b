// Several devices in one process (vk/extract/multi_device.h): lavapipe opened two and three
// times shares the sparse extraction's batches and gives the one device's mesh byte for byte,
// which is the CPU reference's index by index; the --devices list resolution names what is wrong.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/multi_device.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_batches.h"
#include "joining_sink.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::testing {
namespace {

// The fixture's device plus two more contexts on the same physical device (each its own
// instance, VkDevice, pipelines and buffers), validated like the fixture's.
class MultiDeviceTest : public VulkanTest {
 protected:
  static void SetUpTestSuite() {
    VulkanTest::SetUpTestSuite();
    if (!vk::vulkanAvailable() || !more_.empty()) return;
    vk::StandaloneOptions options;
    options.validation = true;
    options.pipelineCache = "off";
    if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
    for (int i = 0; i < 2; ++i) more_.push_back(std::make_unique<vk::StandaloneContext>(options));
  }
  static void TearDownTestSuite() { more_.clear(); }

  void TearDown() override {
    for (const auto& c : more_) EXPECT_EQ(c->validationMessages(), 0u) << "validation on an added device";
    VulkanTest::TearDown();
  }

  static std::vector<vk::Device*> devices(std::size_t n) {
    std::vector<vk::Device*> list{&device()};
    for (std::size_t i = 0; i + 1 < n; ++i) list.push_back(&more_[i]->device());
    return list;
  }

  static inline std::vector<std::unique_ptr<vk::StandaloneContext>> more_;
};

// The CPU polygonizer as a batch worker: one thread, its MPUs the job's bricks of `brickCells`,
// so its layers are the batches' brick layers (it is handed that brick size, or the test fails).
struct CpuWorker {
  cpu::LayerPolygonizer layers;
  vk::HostBatchWorker host;
  static cpu::MpuOptions mpuOptions(std::uint32_t brickCells) {
    cpu::MpuOptions mpu;
    mpu.threads = 1;
    mpu.mpuCells = int(brickCells);
    return mpu;
  }
  CpuWorker(const ShippedScene& sc, std::uint32_t brickCells) : layers(sc.program, sc.grid, mpuOptions(brickCells)) {
    host.run = [this, brickCells](std::uint32_t first, std::uint32_t end, std::uint32_t cells) {
      EXPECT_EQ(cells, brickCells);  // its layers are the MPU layers it was built with
      return cpu::polygonizeLayerRange(layers, int(first), int(end));
    };
  }
  CpuWorker(const CpuWorker&) = delete;
  CpuWorker& operator=(const CpuWorker&) = delete;
};

// 1, 2 and 3 devices, batches chosen per device count or as small as two bricks: the bytes of one
// device, which are the CPU reference's mesh; bricks are dropped, every batch is run exactly once
// and each device's memory follows its batches, not the job.
TEST_F(MultiDeviceTest, SeveralDevicesGiveTheOneDeviceBytes) {
  for (const char* name : {"tower", "dice", "twisted_column"}) {
    const ShippedScene sc = shipped(name, 36);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 4;
    vk::GpuStats oneStats;
    const mesh::TriMesh one = vk::polygonize(device(), sc.program, sc.grid, o, &oneStats);
    ASSERT_GT(one.triangleCount(), 100u) << name;
    expectSameMeshAsReference(one, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, name);
    const std::pair<std::size_t, std::uint32_t> runs[] = {{2, 0}, {2, 9}, {3, 0}, {3, 2}};
    for (const auto& [n, batchBricks] : runs) {
      {
        o.maxBatchBricks = batchBricks;
        vk::GpuStats st;
        std::vector<vk::GpuStats> shares;
        const auto list = devices(n);
        const mesh::TriMesh m = vk::polygonizeOnDevices(list, sc.program, sc.grid, o, &st, &shares);
        const std::string what = std::string(name) + ", " + std::to_string(n) + " devices, batches of " +
                                 (batchBricks ? std::to_string(batchBricks) + " bricks" : "the default");
        expectSameBytes(m, one, what);
        EXPECT_EQ(st.devices, n) << what;
        EXPECT_LT(st.activeBricks, st.bricks) << what << ": no brick dropped";
        EXPECT_GE(st.batches, batchBricks ? 4u : 2u) << what;
        EXPECT_EQ(st.submits, 1 + 2 * st.batches) << what;
        ASSERT_EQ(shares.size(), n) << what;
        std::uint32_t run = 0;
        for (const vk::GpuStats& share : shares) {
          run += share.batches;
          EXPECT_GT(share.deviceBytes, 0u) << what;
          if (batchBricks) {
            EXPECT_LT(share.deviceBytes, oneStats.deviceBytes) << what;
          }
        }
        EXPECT_EQ(run, st.batches) << what;
      }
      o.maxBatchBricks = 0;
    }
  }
}

// The CPU polygonizer as one more worker beside one or two devices: its pieces (the MPU layers
// that are the batches' brick layers) join into the one device's bytes, it takes batches of its
// own, and brick layers with no active brick are skipped by both.
TEST_F(MultiDeviceTest, TheCpuAsOneMoreWorkerGivesTheOneDeviceBytes) {
  // The CPU's bytes are lavapipe's (the same IEEE arithmetic); a GPU's are not, so it refuses them.
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the CPU worker joins lavapipe only";
  for (const char* name : {"tower", "dice"}) {
    const ShippedScene sc = shipped(name, 40);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 4;
    const mesh::TriMesh one = vk::polygonize(device(), sc.program, sc.grid, o);
    CpuWorker cpu(sc, o.brickCells);
    for (std::size_t n : {1u, 2u}) {
      for (std::uint32_t batchBricks : {0u, 6u}) {
        o.maxBatchBricks = batchBricks;
        vk::GpuStats st;
        std::vector<vk::GpuStats> shares;
        const mesh::TriMesh m = vk::polygonizeOnDevices(devices(n), sc.program, sc.grid, o, &st, &shares, &cpu.host);
        const std::string what = std::string(name) + ", " + std::to_string(n) + " devices and the CPU, batches of " +
                                 (batchBricks ? std::to_string(batchBricks) + " bricks" : "the default");
        expectSameBytes(m, one, what);
        ASSERT_EQ(shares.size(), n + 1) << what;
        std::uint32_t run = 0;
        for (const vk::GpuStats& share : shares) run += share.batches;
        EXPECT_EQ(run, st.batches) << what;
        if (batchBricks) {
          EXPECT_GE(st.batches, 6u) << what;
          EXPECT_GT(shares.back().batches, 0u) << what << ": the CPU took no batch";
        }
      }
    }
    o.maxBatchBricks = 0;
  }
}

// Where lavapipe and the CPU differ (llvmpipe's pow, sin and cos), which batches the CPU took
// would show in the bytes: the CPU worker refuses such programs, naming what it found.
TEST_F(MultiDeviceTest, TheCpuWorkerRefusesProgramsLavapipeDoesNotComputeBitForBit) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the CPU worker joins lavapipe only";
  vk::HostBatchWorker host;
  host.run = [](std::uint32_t, std::uint32_t, std::uint32_t) -> mesh::TriMesh {
    ADD_FAILURE() << "the CPU worker ran a batch of a program it must refuse";
    return {};
  };
  // twisted_column twists; creature has a bend and a Ricci blend, whichever its code reaches first.
  for (const auto& [name, found] : {std::pair{"twisted_column", "a twist warp"}, std::pair{"creature", "a "}}) {
    const ShippedScene sc = shipped(name, 24);
    try {
      (void)vk::polygonizeOnDevices(devices(1), sc.program, sc.grid, {}, nullptr, nullptr, &host);
      ADD_FAILURE() << name << ": no error";
    } catch (const vk::VulkanError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("this one has ") + found), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("without the CPU worker"), std::string::npos) << e.what();
    }
  }
}

// Streamed (a mesh larger than the host's memory) on two devices, and on one device with the CPU
// beside it: the runs join into the one device's bytes, every triangle's corners lie in the window
// it comes with, and the host holds a few batches, not the mesh.
TEST_F(MultiDeviceTest, StreamedOnSeveralWorkersGivesTheOneDeviceBytes) {
  const ShippedScene sc = shipped("tower", 48);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  o.brickCells = 4;
  const mesh::TriMesh one = vk::polygonize(device(), sc.program, sc.grid, o);
  CpuWorker cpu(sc, o.brickCells);
  const bool cpuWorker = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;  // it joins lavapipe only
  for (const auto& [n, withHost] : {std::pair{std::size_t(2), false}, {std::size_t(1), true}, {std::size_t(2), true}}) {
    if (withHost && !cpuWorker) continue;
    const std::string what = std::to_string(n) + (withHost ? " devices and the CPU" : " devices");
    o.maxBatchBricks = 8;
    JoiningSink sink;
    vk::GpuStats st;
    std::vector<vk::GpuStats> shares;
    std::size_t lastDone = 0, total = 0;
    vk::polygonizeOnDevicesStreamed(devices(n), sc.program, sc.grid, o, sink, &st, &shares, withHost ? &cpu.host : nullptr,
                                    [&](std::size_t done, std::size_t all) { lastDone = done, total = all; });
    ASSERT_GE(st.batches, 6u) << what;
    expectJoinedRuns(sink, st.batches, one, what);
    EXPECT_EQ(lastDone, total) << what;
    EXPECT_EQ(total, st.batches) << what;
    EXPECT_LT(sink.largestWindow, one.positions.size() / 2) << what << ": a window as large as the mesh";
    ASSERT_EQ(shares.size(), n + (withHost ? 1 : 0)) << what;
    // Who took which batch is timing (a device still building its kernels may take none): every
    // batch ran exactly once.
    std::uint32_t run = 0;
    for (const vk::GpuStats& share : shares) run += share.batches;
    EXPECT_EQ(run, st.batches) << what;
  }
}

// The specialised evaluator (generated code, compiled on each device) gives the same bytes too.
TEST_F(MultiDeviceTest, GeneratedKernelsOnEachDeviceGiveTheSameBytes) {
  const ShippedScene sc = shipped("tower_L6P8I4", 48);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Specialised;
  o.brickCells = 8;
  const mesh::TriMesh one = vk::polygonize(device(), sc.program, sc.grid, o);
  vk::GpuStats st;
  const mesh::TriMesh two = vk::polygonizeOnDevices(devices(2), sc.program, sc.grid, o, &st);
  EXPECT_GE(st.batches, 2u);
  expectSameBytes(two, one, "tower_L6P8I4, specialised");
}

// The classification's tables in windows of brick layers (vk::ScanWindow), copied to the other
// device window by window: the one-device bytes, batches within the windows.
TEST_F(MultiDeviceTest, WindowsOfTheBrickTablesGiveTheOneDeviceBytes) {
  const ShippedScene sc = shipped("tower", 36);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  o.brickCells = 4;
  const mesh::TriMesh one = vk::polygonize(device(), sc.program, sc.grid, o);
  o.windowLayers = 2;
  vk::GpuStats st;
  const mesh::TriMesh two = vk::polygonizeOnDevices(devices(2), sc.program, sc.grid, o, &st);
  const std::uint32_t windows = (vk::brickGridFor(sc.grid, 4).z + 1) / 2;
  EXPECT_GE(st.batches, windows);
  EXPECT_EQ(st.submits, 2 * windows + 2 * st.batches);  // two per window: count, then compact
  expectSameBytes(two, one, "tower, windows of 2 brick layers");
}

TEST_F(MultiDeviceTest, RefusesWhatCannotBeSplit) {
  const ShippedScene sc = shipped("dice", 24);
  vk::Device* same[2] = {&device(), &device()};
  EXPECT_THROW(vk::polygonizeOnDevices(same, sc.program, sc.grid), vk::VulkanError);
  vk::GpuPolygonizeOptions dense;
  dense.sparse = false;
  EXPECT_THROW(vk::polygonizeOnDevices(devices(2), sc.program, sc.grid, dense), vk::VulkanError);
  EXPECT_THROW(vk::polygonizeOnDevices(std::span<vk::Device* const>{}, sc.program, sc.grid), vk::VulkanError);
}

// A device that fails (every allocation refused, as a full heap does) ends the job with its
// error, after the other devices stop: no hang, no partial mesh.
TEST_F(MultiDeviceTest, AFailingDeviceEndsTheJobWithItsError) {
  const ShippedScene sc = shipped("dice", 32);
  vk::MemorySimulation full;
  full.properties = more_[1]->device().memory().properties();
  full.refuse = [](std::uint32_t, VkDeviceSize) { return true; };
  vk::DeviceOptions options;
  options.memorySimulation = &full;
  vk::Device failing(more_[1]->host(), options);  // more_[1]'s own Device stays idle meanwhile
  vk::Device* list[3] = {&device(), &more_[0]->device(), &failing};
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  o.brickCells = 4;
  try {
    vk::polygonizeOnDevices(list, sc.program, sc.grid, o);
    ADD_FAILURE() << "no error";
  } catch (const vk::VulkanError& e) {
    EXPECT_NE(std::string(e.what()).find("memory"), std::string::npos) << e.what();
  }
  // The devices that worked are still usable: the next job gives the one-device bytes.
  vk::Device* two[2] = {&device(), &more_[0]->device()};
  expectSameBytes(vk::polygonizeOnDevices(two, sc.program, sc.grid, o), vk::polygonize(device(), sc.program, sc.grid, o),
                  "after a failed job");
}

// A grid away from the model: no active brick, an empty mesh, on two devices as on one.
TEST_F(MultiDeviceTest, NoActiveBrickIsAnEmptyMesh) {
  const ShippedScene sc = shipped("dice", 24);
  blobtree::GridSpec grid = sc.grid;
  grid.origin = {500.0f, 500.0f, 500.0f};
  vk::GpuStats st;
  const mesh::TriMesh m = vk::polygonizeOnDevices(devices(2), sc.program, grid, {}, &st);
  EXPECT_EQ(m.triangleCount(), 0u);
  EXPECT_EQ(st.activeBricks, 0u);
  EXPECT_EQ(st.batches, 0u);
}

// The batch plan for several devices (no Vulkan needed): every active brick is emitted by exactly
// one batch, in order; batches end at the layer boundary nearest the share asked for, and the
// memory limit still bounds what a batch loads.
TEST(BatchPlan, SharesEndAtTheNearestLayerBoundaryWithinTheLimit) {
  const std::vector<std::uint32_t> starts{0, 10, 20, 20, 45, 50, 60, 61, 80};  // layer 2 empty
  auto check = [&](const std::vector<vk::SparseBatch>& plan) {
    std::uint32_t next = 0;
    for (const vk::SparseBatch& b : plan) {
      EXPECT_EQ(b.activeBase, next);
      EXPECT_GT(b.ownActive, 0u);
      EXPECT_GE(b.loadedActive, b.ownActive);
      next += b.ownActive;
      EXPECT_LE(b.loadedActive, b.ownActive + 25) << "loads more than the next layer";
    }
    EXPECT_EQ(next, 80u);
  };
  const auto whole = vk::planSparseBatches(starts, 1000, 1000);
  ASSERT_EQ(whole.size(), 1u);
  check(whole);
  const auto halves = vk::planSparseBatches(starts, 1000, 1000, 40);  // boundaries at 20 and 45: 45 is nearer
  ASSERT_EQ(halves.size(), 2u);
  EXPECT_EQ(halves[0].ownActive, 45u);
  EXPECT_EQ(halves[0].loadedActive, 50u);
  check(halves);
  const auto limited = vk::planSparseBatches(starts, 30, 1000, 40);  // the limit wins over the share
  EXPECT_GT(limited.size(), 2u);
  for (const vk::SparseBatch& b : limited) EXPECT_LE(b.loadedActive, 30u);
  check(limited);
  const auto tiny = vk::planSparseBatches(starts, 1000, 1000, 1);  // smaller than a layer: one layer each
  EXPECT_EQ(tiny.size(), 7u);
  check(tiny);
  EXPECT_THROW(vk::planSparseBatches(starts, 1000, 20), vk::VulkanError);  // two layers over one buffer
  // Batches end where the classification's windows end (layers 3 and 6), whatever the target.
  const std::vector<std::uint32_t> ends{3, 6};
  const auto windowed = vk::planSparseBatches(starts, 1000, 1000, ~0ull, ends);
  ASSERT_EQ(windowed.size(), 3u);
  EXPECT_EQ(windowed[0].endLayer, 3u);
  EXPECT_EQ(windowed[1].firstLayer, 3u);
  EXPECT_EQ(windowed[1].endLayer, 6u);
  EXPECT_EQ(windowed[2].endLayer, 8u);
  check(windowed);  // A layer pair over one buffer: refused, or with keyed corners that layer alone (layers 3-4
  // hold 25 + 5 bricks, over 26; layer 3 alone fits), the next layer not loaded.
  EXPECT_THROW(vk::planSparseBatches(starts, 26, 26), vk::VulkanError);
  const auto keyed = vk::planSparseBatches(starts, 26, 26, ~0ull, {}, vk::KeyedBatches::Allow);
  check(keyed);
  bool alone = false;
  for (const vk::SparseBatch& b : keyed) {
    EXPECT_LE(b.loadedActive, 26u);
    if (b.keyedCorners) {
      alone = true;
      EXPECT_EQ(b.endLayer, b.firstLayer + 1);
      EXPECT_EQ(b.loadedActive, b.ownActive);
    }
  }
  EXPECT_TRUE(alone);
  const auto forced = vk::planSparseBatches(starts, 1000, 1000, ~0ull, {}, vk::KeyedBatches::Force);
  EXPECT_EQ(forced.size(), 7u);  // one per non-empty layer
  check(forced);
}

// --devices resolution over a made-up device list (no Vulkan needed).
TEST(DeviceList, ResolvesIndicesNamesRepeatsAndAll) {
  std::vector<vk::DeviceInfo> infos(3);
  infos[0].name = "llvmpipe (LLVM 15.0.6, 256 bits)";
  infos[0].type = VK_PHYSICAL_DEVICE_TYPE_CPU;
  infos[1].name = "NVIDIA H100";
  infos[1].type = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
  infos[2].name = "AMD Radeon";
  infos[2].type = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
  using L = std::vector<std::size_t>;
  EXPECT_EQ(vk::resolveDeviceList("all", infos), (L{1, 2}));  // the software device only without GPUs
  EXPECT_EQ(vk::resolveDeviceList("ALL", {infos[0]}), (L{0}));
  EXPECT_EQ(vk::resolveDeviceList("0,0", infos), (L{0, 0}));
  EXPECT_EQ(vk::resolveDeviceList("nvidia, 2 ,LLVMPIPE", infos), (L{1, 2, 0}));
  auto error = [&](const std::string& list) {
    try {
      vk::resolveDeviceList(list, infos);
    } catch (const vk::VulkanError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("0,,1"), "--devices '0,,1': entry 2 is empty (a comma-separated list of device indices or names, or all)");
  EXPECT_EQ(error(""), "--devices '': entry 1 is empty (a comma-separated list of device indices or names, or all)");
  EXPECT_EQ(error("1,intel"), "--devices '1,intel': entry 'intel' matches no Vulkan device (see `blobvk devices`)");
  EXPECT_EQ(error("3"), "--devices '3': entry '3': only 3 Vulkan device(s) (see `blobvk devices`)");
  EXPECT_EQ(error("99999999999999999999"),
            "--devices '99999999999999999999': entry '99999999999999999999': only 3 Vulkan device(s) (see `blobvk devices`)");
  std::string many = "0";
  for (int i = 0; i < 64; ++i) many += ",0";
  EXPECT_NE(error(many).find("65 entries, at most 64"), std::string::npos);
}

}  // namespace
}  // namespace blobvk::testing
