// The sparse brick extraction (vk/extract/sparse_polygonizer.h) against the CPU oracles: the
// classification never drops a brick whose grid samples straddle the iso value (checked sample by
// sample with the scalar reference), and every brick size gives the reference mesh index by index,
// on grids whose cell counts are not multiples of the brick size.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "models.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>

namespace blobvk::testing {
namespace {


class SparseClassification : public VulkanTest, public ::testing::WithParamInterface<std::string> {};

// An inactive brick must have all (B+1)^3 samples of the reference field on one side of the iso
// value; and on the benchmark scenes some bricks are dropped (the extraction is sparse). Both
// classification kernels (records in uniform or in storage buffers) give the same flags. The
// same holds tile by tile with pruned tapes (classify_tiles.h), which drop every brick the whole
// program drops.
TEST_P(SparseClassification, NeverDropsABrickThatHoldsSurface) {
  const ShippedScene s = shipped(GetParam(), 40);
  int tiledSizes = 0;
  for (std::uint32_t brickCells : {4u, 8u})
  for (bool tiled : {false, true}) {
    const vk::BrickGrid bg = vk::brickGridFor(s.grid, brickCells);
    const std::vector<std::uint32_t> whole = vk::classifyBricks(device(), s.program, s.grid, brickCells);
    std::uint32_t tiles = 0;
    const std::vector<std::uint32_t> active =
        tiled ? vk::classifyBricks(device(), s.program, s.grid, brickCells, true, vk::ClassifyCode::Interpreter,
                                   vk::kMaxClassifyTiles, &tiles)
              : whole;
    ASSERT_EQ(active.size(), bg.count());
    if (tiled) {
      if (tiles < 2) continue;  // the plan is one tile: the whole program's flags
      ++tiledSizes;
      std::uint32_t storageTiles = 0;
      EXPECT_EQ(vk::classifyBricks(device(), s.program, s.grid, brickCells, false, vk::ClassifyCode::Interpreter,
                                   vk::kMaxClassifyTiles, &storageTiles),
                active)
          << GetParam();
      EXPECT_EQ(storageTiles, tiles) << GetParam();
      for (std::size_t i = 0; i < active.size(); ++i)
        if (!whole[i]) {
          EXPECT_EQ(active[i], 0u) << GetParam() << " B=" << brickCells << ": brick " << i;
        }
    } else {
      // The records in uniform buffers (where they fit) and in storage buffers: the same bound.
      EXPECT_EQ(vk::classifyBricks(device(), s.program, s.grid, brickCells, false), active) << GetParam();
    }
    std::size_t dropped = 0, wrong = 0;
    for (std::uint32_t bz = 0; bz < bg.z; ++bz)
      for (std::uint32_t by = 0; by < bg.y; ++by)
        for (std::uint32_t bx = 0; bx < bg.x; ++bx) {
          if (active[(std::size_t(bz) * bg.y + by) * bg.x + bx]) continue;
          ++dropped;
          int inside = 0, samples = 0;
          for (std::uint32_t k = bz * brickCells; k <= std::min<std::uint32_t>((bz + 1) * brickCells, s.grid.cells.z); ++k)
            for (std::uint32_t j = by * brickCells; j <= std::min<std::uint32_t>((by + 1) * brickCells, s.grid.cells.y); ++j)
              for (std::uint32_t i = bx * brickCells; i <= std::min<std::uint32_t>((bx + 1) * brickCells, s.grid.cells.x); ++i) {
                inside += blobtree::evaluate(s.program, s.grid.point(int(i), int(j), int(k))) >= layout::ISO_VALUE;
                ++samples;
              }
          if (inside != 0 && inside != samples) ++wrong;
        }
    EXPECT_EQ(wrong, 0u) << GetParam() << " B=" << brickCells << (tiled ? ", tiles" : "");
    if (GetParam() == "tower" || GetParam() == "random128" || GetParam() == "eggshell") {
      EXPECT_GT(dropped, active.size() / 4) << GetParam() << " B=" << brickCells << ": too few dropped";
    }
  }
  if (GetParam() == "tower" || GetParam() == "random128") {
    EXPECT_EQ(tiledSizes, 2) << GetParam() << ": classified in tiles";
  }
}

INSTANTIATE_TEST_SUITE_P(Shipped, SparseClassification, ::testing::ValuesIn(shippedSceneNames()),
                         [](const auto& info) { return info.param; });

// Every brick size, on a grid of 27 x 35 x 31 cells (not multiples of any brick size),
// gives the reference mesh index by index and the dense pipeline's vertices bit for bit.
TEST_F(VulkanTest, EveryBrickSizeGivesTheReferenceMesh) {
  const auto program = blobtree::compile(testModels()[2].root);
  blobtree::GridSpec grid = blobtree::chooseGrid(program, testBounds(), {});
  grid.cells = {27, 35, 31};
  grid.cellSize = 2.2f / 31.0f;
  grid.origin = {-1.0f, -1.2f, -1.1f};
  const auto ref = cpu::polygonizeReference(program, grid);
  vk::GpuPolygonizeOptions dense;
  dense.sparse = false;
  dense.traversal = vk::Traversal::Stackless;
  const auto d = vk::polygonize(device(), program, grid, dense);
  for (std::uint32_t brickCells : {2u, 4u, 8u, 16u}) {
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = brickCells;
    vk::GpuStats stats;
    const auto m = vk::polygonize(device(), program, grid, o, &stats);
    const std::string what = "B=" + std::to_string(brickCells);
    expectSameMeshAsReference(m, ref, 1e-4f * grid.cellSize, what);
    EXPECT_TRUE(sameBytes(m.positions, d.positions)) << what;
    EXPECT_TRUE(sameBytes(m.normals, d.normals)) << what;
    EXPECT_TRUE(sameBytes(m.colours, d.colours)) << what;
    EXPECT_EQ(stats.brickCells, brickCells);
    // The peak device memory holds at least the outputs, and stays within the estimate that
    // --max-memory uses (an upper bound: it adds the classification's scratch to the batches').
    const std::uint64_t outputs = m.positions.size() * 12 + m.triangles.size() * 12;
    EXPECT_GT(stats.deviceBytes, outputs) << what;
    EXPECT_LE(stats.deviceBytes, vk::sparseDeviceBytes(vk::brickGridFor(grid, brickCells), stats.activeBricks,
                                                       m.positions.size(), m.triangles.size(), true, true))
        << what;
  }
}

// Three submits whatever the mesh; outputs read back through one staging buffer (device memory
// the host cannot read, as on a discrete GPU) give the same bytes as mapped memory; device time
// per phase, where the queue has timestamps, is positive and within the wall time.
TEST_F(VulkanTest, ThreeSubmitsAndStagedReadBackGiveTheSameMesh) {
  const auto program = blobtree::compile(testModels()[2].root);
  blobtree::GridRequest request;
  request.resolution = 40;
  const blobtree::GridSpec grid = blobtree::chooseGrid(program, testBounds(), request);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  o.brickCells = 8;
  vk::GpuStats mappedStats, stagedStats;
  const auto mapped = vk::polygonize(device(), program, grid, o, &mappedStats);
  device().setForceStaging(true);
  const auto staged = vk::polygonize(device(), program, grid, o, &stagedStats);
  device().setForceStaging(false);
  ASSERT_GT(mapped.triangleCount(), 100u);
  EXPECT_TRUE(sameBytes(staged.positions, mapped.positions));
  EXPECT_TRUE(sameBytes(staged.normals, mapped.normals));
  EXPECT_TRUE(sameBytes(staged.colours, mapped.colours));
  EXPECT_TRUE(sameBytes(staged.edgeKeys, mapped.edgeKeys));
  EXPECT_TRUE(sameBytes(staged.triangles, mapped.triangles));
  for (const vk::GpuStats& st : {mappedStats, stagedStats}) {
    EXPECT_EQ(st.submits, 3u);
    // The host's steps are disjoint spans of the job's wall time, each one taken (the copies
    // made during the emit submit, with a read-back copy, counted in both).
    const vk::HostSteps& h = st.hostSteps;
    for (double step : {h.classification, h.preparation, h.fieldSubmits, h.emitSubmits, h.grow, h.copy})
      EXPECT_GT(step, 0.0);
    EXPECT_LE(h.classification + h.preparation + h.fieldSubmits + h.emitSubmits + h.corners, st.seconds);
    EXPECT_LE(h.copy, st.seconds);
    EXPECT_EQ(h.corners, 0.0);  // one batch: no keyed corners
    EXPECT_EQ(st.deviceTimed, device().timestampPeriodNs() > 0.0);
    if (!st.deviceTimed) continue;
    EXPECT_GT(st.classifySeconds, 0.0);
    EXPECT_GT(st.fieldSeconds, 0.0);
    EXPECT_GT(st.extractSeconds, 0.0);
    EXPECT_LE(st.classifySeconds + st.fieldSeconds + st.extractSeconds + st.readbackSeconds, st.seconds);
    EXPECT_NEAR(st.hostSeconds + st.classifySeconds + st.fieldSeconds + st.extractSeconds + st.readbackSeconds,
                st.seconds, 1e-9);
  }
  if (device().timestampPeriodNs() > 0.0) {
    EXPECT_GT(stagedStats.readbackDeviceSeconds, 0.0);
    EXPECT_LE(stagedStats.readbackDeviceSeconds, stagedStats.readbackSeconds);
  }
  // Staged in several batches: each batch's arrays grow (while the device copies) after the last
  // batch's rows.
  o.maxBatchBricks = 6;
  device().setForceStaging(true);
  vk::GpuStats batchedStats;
  const auto batched = vk::polygonize(device(), program, grid, o, &batchedStats);
  device().setForceStaging(false);
  EXPECT_GE(batchedStats.batches, 3u);
  EXPECT_TRUE(sameBytes(batched.positions, mapped.positions));
  EXPECT_TRUE(sameBytes(batched.normals, mapped.normals));
  EXPECT_TRUE(sameBytes(batched.colours, mapped.colours));
  EXPECT_TRUE(sameBytes(batched.edgeKeys, mapped.edgeKeys));
  EXPECT_TRUE(sameBytes(batched.triangles, mapped.triangles));
}

// Bricks in batches of brick layers (each holding one layer more than it emits) give the same
// bytes as one batch, and the reference mesh, however small the batches; a job is 1 + 2 x
// batches submits.
TEST_F(VulkanTest, BatchesOfBrickLayersGiveTheSameBytes) {
  for (const char* name : {"tower", "dice", "twisted_column"}) {
    const ShippedScene sc = shipped(name, 40);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 4;
    vk::GpuStats one;
    const auto whole = vk::polygonize(device(), sc.program, sc.grid, o, &one);
    EXPECT_EQ(one.batches, 1u) << name;
    expectSameMeshAsReference(whole, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, name);
    for (std::uint32_t batchBricks : {1u, 7u, 60u}) {
      o.maxBatchBricks = batchBricks;
      vk::GpuStats st;
      const auto m = vk::polygonize(device(), sc.program, sc.grid, o, &st);
      const std::string what = std::string(name) + ", batches of " + std::to_string(batchBricks) + " bricks";
      EXPECT_GT(st.batches, 1u) << what;
      EXPECT_EQ(st.submits, 1 + 2 * st.batches) << what;
      expectSameBytes(m, whole, what);
    }
  }
}

// Meshing into an earlier mesh's arrays (vk::polygonizeInto, what an engine re-meshing and bench's
// repeats do): the reference mesh and polygonize's bytes, in batches too; nothing of the earlier
// mesh stays (arrays this job does not fill come back empty); where the arrays hold room enough
// they are filled where they are, not allocated again.
TEST_F(VulkanTest, MeshingIntoAnEarlierMeshsArraysGivesTheSameBytes) {
  const ShippedScene large = shipped("tower", 48), sc = shipped("tower", 40);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  o.brickCells = 4;
  const auto fresh = vk::polygonize(device(), sc.program, sc.grid, o);
  expectSameMeshAsReference(fresh, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, "fresh");
  for (std::uint32_t batchBricks : {0u, 7u}) {
    const std::string what = "batches of " + std::to_string(batchBricks) + " bricks";
    o.maxBatchBricks = batchBricks;
    mesh::TriMesh mesh = vk::polygonize(device(), large.program, large.grid, o);
    ASSERT_GT(mesh.positions.size(), fresh.positions.size()) << what;
    const auto* positions = mesh.positions.data();
    const auto* triangles = mesh.triangles.data();
    vk::polygonizeInto(device(), sc.program, sc.grid, o, mesh);
    expectSameBytes(mesh, fresh, what);
    EXPECT_EQ(mesh.positions.data(), positions) << what;
    EXPECT_EQ(mesh.triangles.data(), triangles) << what;
    // Without normals and colours: those arrays are emptied, the rest are the job's.
    vk::GpuPolygonizeOptions bare = o;
    bare.normals = bare.colours = false;
    vk::polygonizeInto(device(), sc.program, sc.grid, bare, mesh);
    EXPECT_TRUE(mesh.normals.empty()) << what;
    EXPECT_TRUE(mesh.colours.empty()) << what;
    EXPECT_TRUE(sameBytes(mesh.positions, fresh.positions)) << what;
    EXPECT_TRUE(sameBytes(mesh.triangles, fresh.triangles)) << what;
    EXPECT_TRUE(sameBytes(mesh.edgeKeys, fresh.edgeKeys)) << what;
    // From an empty mesh, arrays that grow as the batches come.
    mesh::TriMesh empty;
    vk::polygonizeInto(device(), sc.program, sc.grid, o, empty);
    expectSameBytes(empty, fresh, what + ", into an empty mesh");
  }
}

// The classification's tables in windows of brick layers (what a grid too large for one buffer
// of flags gets, vk::ScanWindow): the same layer starts as one window (the oracle: the whole
// grid's scan), batches that never cross a window, and the bytes of one window, which are the
// reference mesh; a job is two submits per window (one for a single window) and two per batch. In bricks of 2 the grid is
// large enough for coarser levels of bricks, which then come in the same windows.
TEST_F(VulkanTest, WindowsOfTheBrickTablesGiveTheSameBytes) {
  for (const char* name : {"tower", "dice", "twisted_column"})
  for (std::uint32_t brickCells : {4u, 2u}) {
    const ShippedScene sc = shipped(name, 40);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = brickCells;
    const vk::BrickGrid bricks = vk::brickGridFor(sc.grid, brickCells);
    if (brickCells == 2) {
      ASSERT_GE(bricks.count(), 512u) << name << ": too few bricks for a coarser level";
    }
    vk::GpuStats one;
    const auto whole = vk::polygonize(device(), sc.program, sc.grid, o, &one);
    expectSameMeshAsReference(whole, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, name);
    vk::GpuStats wholeStats;
    const vk::ClassifiedBricks wholeTables = vk::classifyAndCompact(device(), sc.program, sc.grid, bricks, wholeStats);
    ASSERT_EQ(wholeTables.windows.size(), 1u) << name;
    for (std::uint32_t windowLayers : {1u, 2u, 3u}) {
      for (std::uint32_t batchBricks : {0u, 7u}) {
        if (brickCells == 2 && batchBricks) continue;  // batches are bricks-of-4's business
        const std::string what = std::string(name) + ", B=" + std::to_string(brickCells) + ", windows of " + std::to_string(windowLayers) +
                                 " layers, batches of " + std::to_string(batchBricks) + " bricks";
        vk::GpuStats cs;
        std::vector<std::pair<std::size_t, std::size_t>> progress;
        const vk::ClassifiedBricks tables =
            vk::classifyAndCompact(device(), sc.program, sc.grid, bricks, cs, nullptr, windowLayers, vk::ClassifyChoice{},
                                   {[&](std::size_t done, std::size_t total) { progress.emplace_back(done, total); }});
        EXPECT_EQ(tables.windows.size(), (bricks.z + windowLayers - 1) / windowLayers) << what;
        // Progress: one report per window, in order, where there are several.
        const std::size_t n = tables.windows.size();
        ASSERT_EQ(progress.size(), n > 1 ? n : 0u) << what;
        for (std::size_t k = 0; k < progress.size(); ++k) EXPECT_EQ(progress[k], std::make_pair(k + 1, n)) << what;
        EXPECT_EQ(tables.layerStarts, wholeTables.layerStarts) << what;
        EXPECT_EQ(tables.downloadList(device(), 0, tables.layerStarts.back()),
                  wholeTables.downloadList(device(), 0, wholeTables.layerStarts.back()))
            << what;
        o.windowLayers = windowLayers;
        o.maxBatchBricks = batchBricks;
        vk::GpuStats st;
        const auto m = vk::polygonize(device(), sc.program, sc.grid, o, &st);
        // Several windows take two submits each (count the active bricks, then list them), one takes one.
        const std::size_t classifySubmits = tables.windows.size() > 1 ? 2 * tables.windows.size() : 1;
        EXPECT_EQ(st.submits, classifySubmits + 2 * st.batches) << what;
        std::uint32_t windowsWithBricks = 0;
        for (const vk::ScanWindow& w : tables.windows)
          windowsWithBricks += tables.layerStarts[w.endLayer] > tables.layerStarts[w.firstLayer];
        EXPECT_GE(st.batches, windowsWithBricks) << what << ": a batch crossed a window";
        expectSameBytes(m, whole, what);
      }
    }
  }
}

// Batches of one brick layer whose triangles come back as corner keys and are matched on the host
// (what a layer pair over one storage buffer gets, sparse_batches.h): one batch per non-empty
// layer, the bytes of one batch, which are the reference mesh, also in windows of the tables.
TEST_F(VulkanTest, KeyedCornerBatchesGiveTheSameBytes) {
  for (const char* name : {"tower", "dice", "twisted_column"}) {
    const ShippedScene sc = shipped(name, 40);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 4;
    const auto whole = vk::polygonize(device(), sc.program, sc.grid, o);
    expectSameMeshAsReference(whole, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, name);
    vk::GpuStats cs;
    const vk::ClassifiedBricks tables =
        vk::classifyAndCompact(device(), sc.program, sc.grid, vk::brickGridFor(sc.grid, 4), cs);
    std::uint32_t layers = 0;
    for (std::size_t z = 0; z + 1 < tables.layerStarts.size(); ++z) layers += tables.layerStarts[z + 1] > tables.layerStarts[z];
    for (std::uint32_t windowLayers : {0u, 2u}) {
      const std::string what = std::string(name) + ", windows of " + std::to_string(windowLayers) + " layers";
      o.keyedCornerBatches = true;
      o.windowLayers = windowLayers;
      vk::GpuStats st;
      const auto m = vk::polygonize(device(), sc.program, sc.grid, o, &st);
      EXPECT_EQ(st.batches, layers) << what;
      EXPECT_GT(st.hostSteps.corners, 0.0) << what;
      expectSameBytes(m, whole, what);
    }
  }
}

// Pencils of 2100 cells along each axis through the model, in bricks of 2: 1050 bricks along the
// pencil, so its coordinate takes 11 bits of the packed brick word and the others 2 (BrickGrid::pack).
// Each gives the reference mesh index by index.
TEST_F(VulkanTest, MoreThan1024BricksAlongAnAxisGiveTheReferenceMesh) {
  const auto program = blobtree::compile(testModels()[2].root);
  for (int axis = 0; axis < 3; ++axis) {
    blobtree::GridSpec grid;
    grid.cells = {6, 5, 7};
    grid.cells[axis] = 2100;
    grid.cellSize = 2.4f / 2100.0f;
    grid.origin = {-3.0f * grid.cellSize, -2.5f * grid.cellSize, -3.5f * grid.cellSize};
    grid.origin[axis] = -1.2f;
    const vk::BrickGrid bg = vk::brickGridFor(grid, 2);
    const std::uint32_t along[3] = {bg.x, bg.y, bg.z}, bits[3] = {bg.bitsX(), bg.bitsY(), bg.bitsZ()};
    ASSERT_EQ(along[axis], 1050u);
    EXPECT_EQ(bits[axis], 11u);
    const auto ref = cpu::polygonizeReference(program, grid);
    ASSERT_GT(ref.triangleCount(), 0u) << "the pencil along axis " << axis << " misses the surface";
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 2;
    vk::GpuStats stats;
    const auto m = vk::polygonize(device(), program, grid, o, &stats);
    EXPECT_EQ(stats.brickCells, 2u);
    // Cells of 1.1e-3 at coordinates up to 1.2: a few float ulps there (1.2e-7 each) exceed 1e-4 cells.
    expectSameMeshAsReference(m, ref, 1e-6f, "pencil along axis " + std::to_string(axis));
  }
}

// A grid that misses the model: every brick is dropped, the mesh is empty; also with the tables
// in windows of one layer (each window's list counted first: none).
TEST_F(VulkanTest, AGridAwayFromTheModelHasNoActiveBricks) {
  const auto program = blobtree::compile(testModels()[0].root);
  blobtree::GridSpec grid;
  grid.origin = {50.0f, 50.0f, 50.0f};
  grid.cellSize = 0.1f;
  grid.cells = {20, 20, 20};
  for (std::uint32_t windowLayers : {0u, 1u}) {
    vk::GpuPolygonizeOptions o;
    o.brickCells = 8;
    o.windowLayers = windowLayers;
    vk::GpuStats stats;
    const auto m = vk::polygonize(device(), program, grid, o, &stats);
    EXPECT_EQ(m.triangleCount(), 0u);
    EXPECT_EQ(m.vertexCount(), 0u);
    EXPECT_EQ(stats.activeBricks, 0u);
    EXPECT_EQ(stats.bricks, 27u);
  }
}

// n with a comma between groups of three digits, as the phase notes print counts.
std::string groupedForTest(std::uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out.push_back(',');
    out.push_back(digits[i]);
  }
  return out;
}

// The phase notes of a whole job: the classification before it runs, then the active bricks and
// batches (the stats' own figures) before the batches run, nothing else.
TEST_F(VulkanTest, PhaseNotesNameTheClassificationAndTheBatches) {
  const ShippedScene sc = shipped("tower", 96);
  vk::GpuPolygonizeOptions options;
  std::vector<std::string> notes;
  options.phaseNote = [&notes](const std::string& n) { notes.push_back(n); };
  vk::GpuStats stats;
  const mesh::TriMesh mesh = vk::polygonize(device(), sc.program, sc.grid, options, &stats);
  ASSERT_GT(mesh.triangleCount(), 0u);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[0], "classifying " + groupedForTest(stats.bricks) + " bricks of 16x16x16 cells on the device");
  EXPECT_EQ(notes[1], groupedForTest(stats.activeBricks) + " active bricks of " + groupedForTest(stats.bricks) + " in " +
                          std::to_string(stats.batches) + (stats.batches == 1 ? " batch" : " batches"));
  EXPECT_EQ(groupedForTest(1234567), "1,234,567");
  EXPECT_EQ(groupedForTest(123), "123");
}

// A layer pair over one storage buffer is classified again with smaller bricks: with a range
// that two layers of 16³ bricks exceed, the classification comes back in bricks of 8³ whose
// pairs fit, and the largest pair of the first try was indeed over it (the oracle: its own
// layer starts). Halving stops at 4 cells, where the batch planner names what does not fit.
TEST_F(VulkanTest, LayerPairsOverOneStorageBufferTakeSmallerBricks) {
  const ShippedScene sc = shipped("tower", 96);
  vk::GpuStats stats;
  auto largestPair = [](const vk::ClassifiedBricks& c) {
    std::uint32_t most = 0;
    const std::size_t layers = c.layerStarts.size() - 1;
    for (std::size_t z = 0; z < layers; ++z) most = std::max(most, c.layerStarts[std::min(z + 2, layers)] - c.layerStarts[z]);
    return most;
  };
  const auto unlimited = [](const vk::BrickGrid&) { return ~0ull; };
  const vk::ClassifiedBricks at16 = vk::classifyToFit(device(), sc.program, sc.grid, 16, unlimited, stats);
  ASSERT_EQ(at16.bricks.log2B, 4u);
  const std::uint32_t pair16 = largestPair(at16);
  ASSERT_GT(pair16, 4u);
  // Room for the pairs of 8³ bricks (8x smaller records), not for those of 16³.
  const auto range = [pair16](const vk::BrickGrid& b) -> std::uint64_t { return b.log2B >= 4 ? pair16 - 1 : 1000000; };
  std::vector<std::string> notes;
  const vk::ClassifiedBricks fitted = vk::classifyToFit(device(), sc.program, sc.grid, 16, range, stats, 0, {},
                                                        [&notes](const std::string& n) { notes.push_back(n); });
  EXPECT_EQ(fitted.bricks.log2B, 3u);
  // One note per classification, before it runs, the second saying why it runs again.
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[0], "classifying " + groupedForTest(at16.bricks.count()) + " bricks of 16x16x16 cells on the device");
  EXPECT_EQ(notes[1], "two adjacent brick layers hold more active bricks than one storage buffer; classifying " +
                          groupedForTest(fitted.bricks.count()) + " bricks of 8x8x8 cells on the device");
  EXPECT_LE(largestPair(fitted), 1000000u);
  EXPECT_EQ(fitted.layerStarts.back(), stats.activeBricks);
  // In windows of one layer, the classification of 16³ bricks stops at the window of the first
  // pair over the range instead of classifying the rest for nothing; the second, of 8³, gives
  // the same tables.
  std::size_t firstOver = 0;
  while (at16.layerStarts[std::min<std::size_t>(firstOver + 2, at16.bricks.z)] - at16.layerStarts[firstOver] <= pair16 - 1) ++firstOver;
  ASSERT_LT(firstOver + 1, at16.bricks.z) << "the first pair over the range is in the last window: nothing to save";
  std::vector<std::pair<std::size_t, std::size_t>> reports;
  const vk::ClassifiedBricks windowed =
      vk::classifyToFit(device(), sc.program, sc.grid, 16, range, stats, 1, {}, {},
                        [&reports](std::size_t done, std::size_t total) { reports.emplace_back(done, total); });
  EXPECT_EQ(windowed.bricks.log2B, 3u);
  EXPECT_EQ(windowed.layerStarts, fitted.layerStarts);
  EXPECT_FALSE(windowed.abandoned);
  ASSERT_GT(reports.size(), firstOver + 1);
  for (std::size_t k = 0; k <= firstOver; ++k) EXPECT_EQ(reports[k], std::make_pair(k + 1, std::size_t(at16.bricks.z)));
  EXPECT_EQ(reports[firstOver + 1], std::make_pair(std::size_t(1), std::size_t(windowed.bricks.z)));  // the 8³ pass begins
  EXPECT_EQ(reports.back(), std::make_pair(std::size_t(windowed.bricks.z), std::size_t(windowed.bricks.z)));
  // Nothing fits: it stops at bricks of 4³.
  const vk::ClassifiedBricks smallest =
      vk::classifyToFit(device(), sc.program, sc.grid, 16, [](const vk::BrickGrid&) { return 1ull; }, stats);
  EXPECT_EQ(smallest.bricks.log2B, 2u);
  // Where a batch may hold a layer alone (one device, corners matched by key), only a layer over
  // the range halves the bricks: the same range keeps 16³, one below the largest layer does not.
  std::uint32_t layer16 = 0;
  for (std::size_t z = 0; z + 1 < at16.layerStarts.size(); ++z) layer16 = std::max(layer16, at16.layerStarts[z + 1] - at16.layerStarts[z]);
  ASSERT_LT(layer16, pair16);
  notes.clear();
  const vk::ClassifiedBricks alone = vk::classifyToFit(device(), sc.program, sc.grid, 16, range, stats, 0, {},
                                                       [&notes](const std::string& n) { notes.push_back(n); }, {}, 1);
  EXPECT_EQ(alone.bricks.log2B, 4u);
  EXPECT_EQ(alone.layerStarts, at16.layerStarts);
  EXPECT_EQ(notes.size(), 1u);
  const auto belowLayer = [layer16](const vk::BrickGrid& b) -> std::uint64_t { return b.log2B >= 4 ? layer16 - 1 : 1000000; };
  notes.clear();
  const vk::ClassifiedBricks halved = vk::classifyToFit(device(), sc.program, sc.grid, 16, belowLayer, stats, 0, {},
                                                        [&notes](const std::string& n) { notes.push_back(n); }, {}, 1);
  EXPECT_EQ(halved.bricks.log2B, 3u);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[1].rfind("a brick layer holds more active bricks than one storage buffer; classifying", 0), 0u) << notes[1];
}

}  // namespace
}  // namespace blobvk::testing
