// The sparse vertex pass per field tile (GpuPolygonizeOptions::sparseVertexTiles): each tile's
// vertices run by a vertex kernel whose field and generated gradient are pruned to the tile's box
// of bricks. A vertex lies on an edge between two points of its brick, inside that box, so the
// mesh must be the one whole-program kernel gives, byte for byte (positions, normals, colours,
// keys, triangles), and the CPU reference's index by index.
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/gradient_codegen.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

using VertexTiles = vk::GpuPolygonizeOptions::VertexTiles;

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The generated gradient drops the primitives whose support box misses the region, as the field
// code does: far from the model no primitive formula is left, and a tile of the tower keeps fewer
// than the whole program.
TEST(VertexTiles, PrunedGradientDropsPrimitivesOutsideTheRegion) {
  const ShippedScene m = shipped("tower", 64);
  vk::PointRegion far;
  far.valid = true;
  for (int a = 0; a < 3; ++a) far.lo[a] = 1e6f, far.hi[a] = 1e6f + 1.0f;
  vk::CodegenOptions c;
  const std::string whole = vk::generateSpecialisedGradient(m.program, c, "code");
  c.region = far;
  const std::string none = vk::generateSpecialisedGradient(m.program, c, "code");
  const std::string call = " = primitiveGradientOfType";  // a primitive's formula called
  ASSERT_GT(occurrences(whole, call), 0u);
  EXPECT_EQ(occurrences(none, call), 0u) << "no primitive's formula is called far from the model";
  const vk::BrickGrid bg = vk::brickGridFor(m.grid, 8);
  const auto tiles = vk::planBrickTiles(m.program, m.grid, bg, 8);
  ASSERT_GT(tiles.size(), 1u);
  c.region = tiles.front().region;
  EXPECT_LT(occurrences(vk::generateSpecialisedGradient(m.program, c, "code"), call), occurrences(whole, call));
}

struct Case {
  std::string what;
  blobtree::Program program;
  blobtree::GridSpec grid;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const char* name : {"tower", "random128", "dice", "creature"}) {
    ShippedScene s = shipped(name, 48);
    out.push_back({name, std::move(s.program), s.grid});
  }
  // A legacy .blob file (blobtree/scene_blob.h): its own grid.
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/tower_fragment.blob");
  Case legacy{"tower_fragment.blob", blobtree::compile(scene.root), {}};
  blobtree::GridRequest request;
  request.resolution = 48;
  legacy.grid = blobtree::chooseGrid(legacy.program, scene.grid, request);
  out.push_back(std::move(legacy));
  return out;
}

void expectSameBytes(const mesh::TriMesh& m, const mesh::TriMesh& one, const std::string& what) {
  EXPECT_TRUE(sameBytes(m.positions, one.positions)) << what;
  EXPECT_TRUE(sameBytes(m.normals, one.normals)) << what;
  EXPECT_TRUE(sameBytes(m.colours, one.colours)) << what;
  EXPECT_TRUE(sameBytes(m.edgeKeys, one.edgeKeys)) << what;
  EXPECT_TRUE(sameBytes(m.triangles, one.triangles)) << what;
}

// Tiled against untiled and the CPU reference, in one batch and in batches of a few bricks (each
// batch lists its own vertices by tile), without and with refinement steps (the kernel with the
// sample loop, whose field evaluations are pruned too).
TEST_F(VulkanTest, TiledVertexPassGivesTheBytesOfOneKernel) {
  std::size_t tiled = 0;
  for (const Case& c : cases()) {
    for (int refine : {0, 2}) {
      vk::GpuPolygonizeOptions o;
      o.traversal = vk::Traversal::Specialised;
      o.brickCells = 8;
      o.refineSteps = refine;
      o.sparseVertexTiles = VertexTiles::Off;
      vk::GpuStats oneStats;
      const mesh::TriMesh one = vk::polygonize(device(), c.program, c.grid, o, &oneStats);
      const std::string base = c.what + ", refine " + std::to_string(refine);
      EXPECT_EQ(oneStats.vertexTiles, 0u) << base;
      if (refine == 0) {
        cpu::ReferenceOptions r;
        expectSameMeshAsReference(one, cpu::polygonizeReference(c.program, c.grid, r), 1e-4f * c.grid.cellSize, base);
      }
      o.sparseVertexTiles = VertexTiles::On;
      for (std::uint32_t batchBricks : {0u, 9u}) {
        o.maxBatchBricks = batchBricks;
        vk::GpuStats st;
        const mesh::TriMesh m = vk::polygonize(device(), c.program, c.grid, o, &st);
        const std::string what = base + ", batches of " + std::to_string(batchBricks) + " bricks";
        EXPECT_EQ(st.vertexTiles, st.fieldTiles > 1 ? st.fieldTiles : 0u) << what;
        tiled += st.vertexTiles > 1 ? 1 : 0;
        expectSameBytes(m, one, what);
      }
    }
  }
  EXPECT_GE(tiled, 8u) << "tower and random128 at least run their vertex pass per tile";
}

// Auto tiles the vertex pass only where the model predicts the pruned kernels' builds paid back
// by the job's runs: not for one mesh nor a benchmark's few runs of the tower at 256 cells (its
// kernels' warm-cache cost alone is more than the few milliseconds a run saves), but for an engine
// re-meshing it a thousand times; never without field tiles (eggshell).
TEST_F(VulkanTest, AutoTilesTheVertexPassOnlyWhereItPays) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  auto decide = [&](const char* name, std::uint32_t runs) {
    const ShippedScene s = shipped(name, 256);
    vk::GpuPolygonizeOptions o;  // Auto
    o.expectedRuns = runs;
    vk::GpuStats st;
    const vk::ClassifiedBricks classified = vk::classifyToFit(
        device(), s.program, s.grid, o.brickCells, [](const vk::BrickGrid&) { return ~0ull; }, st);
    const vk::SparseEvaluator e = vk::resolveSparseEvaluator(device(), s.program, s.grid, o, &classified);
    return e.apply(o).sparseVertexTiles == VertexTiles::On;
  };
  EXPECT_FALSE(decide("tower", 1));
  EXPECT_FALSE(decide("tower", 4));
  EXPECT_TRUE(decide("tower", 1000));
  EXPECT_FALSE(decide("eggshell", 1000));
}

}  // namespace
}  // namespace blobvk::testing
