// Row culling (vk/extract/row_culling.h): the field pass on llvmpipe skips the rows of points that
// the CPU backend's bound (cpu::ColumnSides, tested against the field in
// tests/cpu_simd/test_column_sides.cpp) proves on one side of the iso-value. With culling, the mesh
// of every shipped scene it applies to is the CPU reference's and the bytes of the run without it,
// in one batch and in batches of a few bricks, with bricks of 16 and 8, on the specialised tiles
// and the interpreter; fewer points are evaluated.
#include "blobvk/cpu_simd/column_sides.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

vk::GpuPolygonizeOptions culling(const std::shared_ptr<cpu::ColumnSides>& sides) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides](const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                         std::uint8_t* out) { (*sides)(x, nx, y, z, n, out); };
  return o;
}

// The same bound over whole columns only: each segment takes its column's side, so a row is
// evaluated whole or not at all.
vk::GpuPolygonizeOptions cullingWholeColumns(const std::shared_ptr<cpu::ColumnSides>& sides) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides](const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                         std::uint8_t* out) {
    const float ends[2] = {x[0], x[nx]};
    std::vector<std::uint8_t> columns(std::size_t(n) * n);
    (*sides)(ends, 1, y, z, n, columns.data());
    for (std::size_t c = 0; c < columns.size(); ++c)
      for (std::uint32_t i = 0; i < nx; ++i) out[i + nx * c] = columns[c];
  };
  return o;
}

TEST_F(VulkanTest, RowCullingGivesTheMeshOfEveryRow) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  std::uint64_t segmentSamples = 0, columnSamples = 0;
  for (const std::string& name : shippedSceneNames()) {
    ShippedScene s = shipped(name, 64);
    if (!cpu::ColumnSides::boundsHoldOnIeeeDevices(s.program)) continue;
    const auto sides = std::make_shared<cpu::ColumnSides>(s.program);
    const mesh::TriMesh reference = cpu::polygonizeReference(s.program, s.grid, {});
    struct Setting {
      std::uint32_t brickCells;
      vk::Traversal traversal;
      std::uint32_t batchBricks;
    };
    for (const Setting& setting : {Setting{16, vk::Traversal::Auto, 0}, Setting{16, vk::Traversal::Stackless, 7},
                                   Setting{8, vk::Traversal::Auto, 7}, Setting{8, vk::Traversal::Stackless, 0}}) {
          const auto [brickCells, traversal, batchBricks] = setting;
          const std::string what = name + ", bricks of " + std::to_string(brickCells) + ", " +
                                   vk::traversalName(traversal) + ", batches of " + std::to_string(batchBricks);
          vk::GpuPolygonizeOptions o = culling(sides);
          o.brickCells = brickCells;
          o.traversal = traversal;
          o.maxBatchBricks = batchBricks;
          vk::GpuStats culled, whole, every;
          const mesh::TriMesh m = vk::polygonize(device(), s.program, s.grid, o, &culled);
          o.columnSides = cullingWholeColumns(sides).columnSides;
          const mesh::TriMesh byColumns = vk::polygonize(device(), s.program, s.grid, o, &whole);
          o.columnSides = nullptr;
          const mesh::TriMesh all = vk::polygonize(device(), s.program, s.grid, o, &every);
          expectSameBytes(m, all, what);
          expectSameBytes(byColumns, all, what + ", whole columns");
          expectSameMeshAsReference(m, reference, 1e-4f * s.grid.cellSize, what);
          // The row lists are in the device memory that --max-memory estimates.
          EXPECT_LE(culled.deviceBytes, vk::sparseDeviceBytes(vk::brickGridFor(s.grid, culled.brickCells), culled.activeBricks,
                                                              m.positions.size(), m.triangles.size(), true, true,
                                                              culled.tapeBytes))
              << what;
          // Every row of an active brick without culling; with whole columns, whole rows and fewer
          // of them; with segments, at most as many points again.
          const std::uint64_t R = every.brickCells + 1;  // tower_L6P8I4 takes 8 on llvmpipe (its loop limit)
          EXPECT_EQ(culled.brickCells, every.brickCells) << what;
          if (every.batches == 1) {
            EXPECT_EQ(every.fieldEvaluations, std::uint64_t(every.activeBricks) * R * R * R) << what;
          }
          EXPECT_EQ(whole.fieldEvaluations % R, 0u) << what;
          EXPECT_LE(culled.fieldEvaluations, whole.fieldEvaluations) << what;
          if (!reference.triangles.empty()) {
            EXPECT_LT(whole.fieldEvaluations, every.fieldEvaluations) << what;
          }
          segmentSamples += culled.fieldEvaluations;
          columnSamples += whole.fieldEvaluations;
        }
  }
  // Segments of four cells along x cull points of rows that whole columns evaluate.
  EXPECT_LT(double(segmentSamples), 0.9 * double(columnSamples));
}

// A bound belongs to one program, and an edit session's programs change: the extractor ignores
// the option. Given a bound that proves every column below the iso-value (wrong for this
// program), it still meshes every row.
TEST_F(VulkanTest, IncrementalExtractionIgnoresARowCullingBound) {
  const ShippedScene s = shipped("tower", 48);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  const mesh::TriMesh whole = vk::polygonize(device(), s.program, s.grid, o);
  ASSERT_GT(whole.triangleCount(), 0u);
  o.columnSides = [](const float*, std::uint32_t nx, const float*, const float*, std::uint32_t n, std::uint8_t* sides) {
    for (std::uint32_t c = 0; c < nx * n * n; ++c) sides[c] = 0;
  };
  vk::IncrementalExtractor inc(device(), s.grid, o);
  expectSameBytes(inc.reset(s.program), whole, "incremental extractor with a wrong bound");
}

}  // namespace
}  // namespace blobvk::testing
