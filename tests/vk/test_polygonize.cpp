#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/mesh/checks.h"
#include "models.h"
#include "reference_checks.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/polygonize.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace blobvk::testing {
namespace {

float dist(const mesh::Float3& a, const mesh::Float3& b) {
  return std::max({std::abs(a.x - b.x), std::abs(a.y - b.y), std::abs(a.z - b.z)});
}

struct Case {
  std::size_t model;
  int resolution;
  int refineSteps;
};

class PolygonizeTest : public VulkanTest, public ::testing::WithParamInterface<Case> {};

TEST_P(PolygonizeTest, MatchesReferenceIndexByIndex) {
  const Case c = GetParam();
  const auto model = testModels()[c.model];
  const auto program = blobtree::compile(model.root);
  blobtree::GridRequest request;
  request.resolution = c.resolution;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);

  // Where the GPU and CPU fields classify a grid point differently the meshes may differ
  // there; the models here keep every sample away from the iso value, so demand identity.
  const auto gpuField = vk::evaluateFieldOnGrid(device(), program, grid);
  std::size_t disagree = 0;
  const auto pts = grid.points();
  for (int k = 0; k < pts.z; ++k)
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i) {
        const float f = blobtree::evaluate(program, grid.point(i, j, k));
        if ((f >= layout::ISO_VALUE) != (gpuField[grid.pointIndex(i, j, k)] >= layout::ISO_VALUE))
          ++disagree;
      }
  ASSERT_EQ(disagree, 0u) << "classification differs: pick another resolution for this model";

  cpu::ReferenceOptions ro;
  ro.refineSteps = c.refineSteps;
  const auto ref = cpu::polygonizeReference(program, grid, ro);
  vk::GpuPolygonizeOptions go;
  go.refineSteps = c.refineSteps;
  vk::GpuStats stats;
  const auto gpu = vk::polygonize(device(), program, grid, go, &stats);

  ASSERT_GT(ref.triangleCount(), 0u);
  ASSERT_EQ(gpu.vertexCount(), ref.vertexCount());
  ASSERT_EQ(gpu.triangleCount(), ref.triangleCount());
  EXPECT_EQ(gpu.edgeKeys, ref.edgeKeys);
  EXPECT_EQ(gpu.triangles, ref.triangles);
  float pos = 0, nrm = 0, col = 0;
  for (std::size_t v = 0; v < ref.vertexCount(); ++v) {
    pos = std::max(pos, dist(gpu.positions[v], ref.positions[v]));
    nrm = std::max(nrm, dist(gpu.normals[v], ref.normals[v]));
    col = std::max(col, dist(gpu.colours[v], ref.colours[v]));
  }
  EXPECT_LT(pos, 1e-4f * grid.cellSize + 1e-6f);
  EXPECT_LT(nrm, 2e-2f);  // central differences with h = 1e-4 amplify float rounding
  EXPECT_LT(col, 1e-4f);
  EXPECT_TRUE(mesh::checkMesh(gpu).watertight());
  EXPECT_GT(stats.activeBricks, 0u);
  EXPECT_LE(stats.activeBricks, stats.bricks);

  // The dense z-slab pipeline too, in one slab.
  go.sparse = false;
  const auto dense = vk::polygonize(device(), program, grid, go, &stats);
  EXPECT_EQ(dense.edgeKeys, ref.edgeKeys);
  EXPECT_EQ(dense.triangles, ref.triangles);
  EXPECT_EQ(stats.bricks, 1u);
}

INSTANTIATE_TEST_SUITE_P(Models, PolygonizeTest,
                         ::testing::Values(Case{0, 12, 0}, Case{1, 20, 0}, Case{2, 32, 0},
                                           Case{1, 20, 3}));

TEST_F(VulkanTest, MultiSlabMeshEqualsSingleSlab) {
  const auto program = blobtree::compile(testModels()[2].root);
  blobtree::GridRequest request;
  request.resolution = 28;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);
  const auto whole = vk::polygonize(device(), program, grid);
  vk::GpuPolygonizeOptions small;
  small.sparse = false;
  const auto pts = grid.points();
  small.maxBrickBytes = std::uint64_t(pts.x) * pts.y * 4 * 5;  // 3 cell layers per slab
  vk::GpuStats stats;
  const auto slabs = vk::polygonize(device(), program, grid, small, &stats);
  EXPECT_GE(stats.bricks, 5u);
  // The oracle is the CPU reference mesh; equality with the one-slab run is the determinism check.
  expectSameMeshAsReference(slabs, cpu::polygonizeReference(program, grid), 1e-4f * grid.cellSize, "slabs");
  EXPECT_EQ(slabs, whole);
}

TEST_F(VulkanTest, StackBasedMeshEqualsStackless) {
  const auto program = blobtree::compile(testModels()[1].root);
  blobtree::GridRequest request;
  request.resolution = 16;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);
  vk::GpuPolygonizeOptions stack;
  stack.traversal = vk::Traversal::StackBased;
  const auto a = vk::polygonize(device(), program, grid);
  const auto b = vk::polygonize(device(), program, grid, stack);
  const auto ref = cpu::polygonizeReference(program, grid);
  expectSameMeshAsReference(b, ref, 1e-4f * grid.cellSize, "stack-based");
  expectSameMeshAsReference(a, ref, 1e-4f * grid.cellSize, "stackless");
}

// The sparse path's classification needs the register code, which the stack-based traversal
// does not upload: on a scene with many bricks, some dropped, the mesh is still the reference.
TEST_F(VulkanTest, StackBasedSparseMeshOfAShippedSceneIsTheReference) {
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/craniotomy.json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = 40;
  const auto grid = blobtree::chooseGrid(program, scene.grid, request);
  const auto ref = cpu::polygonizeReference(program, grid);
  for (std::uint32_t brickCells : {4u, 16u}) {
    vk::GpuPolygonizeOptions stack;
    stack.traversal = vk::Traversal::StackBased;
    stack.brickCells = brickCells;
    vk::GpuStats stats;
    const auto m = vk::polygonize(device(), program, grid, stack, &stats);
    EXPECT_LT(stats.activeBricks, stats.bricks) << "some bricks must be dropped for the test to mean much";
    expectSameMeshAsReference(m, ref, 1e-4f * grid.cellSize, "stack-based, B=" + std::to_string(brickCells));
  }
}

}  // namespace
}  // namespace blobvk::testing
