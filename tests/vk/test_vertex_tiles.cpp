// The sparse vertex pass per field tile (GpuPolygonizeOptions::sparseVertexTiles): each tile's
// vertices run by a vertex kernel whose field and generated gradient are pruned to the tile's box
// of bricks. A vertex lies on an edge between two points of its brick, inside that box, so the
// mesh must be the one whole-program kernel gives, byte for byte (positions, normals, colours,
// keys, triangles), and the CPU reference's index by index.
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "unrolled_code.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

struct Case {
  std::string what;
  blobtree::Program program;
  blobtree::GridSpec grid;
  bool smallBatches = true;  // also in batches of a few bricks (hundreds of submits on a large grid)
};

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const char* name : {"tower", "random128", "dice", "craniotomy"}) {
    ShippedScene s = shipped(name, 48);
    out.push_back({name, std::move(s.program), s.grid});
  }
  // A legacy .blob file (blobtree/scene_blob.h) on its own grid at 256 cells, where vertices lie
  // on its plane of symmetry x = 0 and a normal's x is a signed zero: the gradient's dropped
  // primitives written with literal zeros (vk/eval/gradient_codegen.cpp writes loaded ones) turned
  // -0 into +0 there.
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/tower_fragment.blob");
  Case legacy{"tower_fragment.blob", blobtree::compile(scene.root), {}, false};
  blobtree::GridRequest request;
  request.resolution = 256;
  legacy.grid = blobtree::chooseGrid(legacy.program, scene.grid, request);
  out.push_back(std::move(legacy));
  return out;
}

// Tiled against untiled and the CPU reference, in one batch and in batches of a few bricks (each
// batch lists its own vertices by tile), with the tiles' lists made by the host (CPU devices) and
// by the device, without and with refinement steps (the kernel with the
// sample loop, whose field evaluations are pruned by primitive boxes too). The code is unrolled on
// every driver: tiles whose code loops keep the one kernel (sparse_batches.cpp).
TEST_F(VulkanTest, TiledVertexPassGivesTheBytesOfOneKernel) {
  const vk::CodegenOptions unrolled = unrolledCodegen(device());
  std::size_t tiled = 0;
  for (const Case& c : cases()) {
    for (int refine : {0, 2}) {
      vk::GpuPolygonizeOptions o;
      o.traversal = vk::Traversal::Specialised;
      o.codegen = &unrolled;
      o.brickCells = 8;
      o.refineSteps = refine;
      o.sparseVertexTiles = false;
      vk::GpuStats oneStats;
      const mesh::TriMesh one = vk::polygonize(device(), c.program, c.grid, o, &oneStats);
      const std::string base = c.what + ", refine " + std::to_string(refine);
      EXPECT_EQ(oneStats.vertexTiles, 0u) << base;
      if (refine == 0) {
        cpu::ReferenceOptions r;
        expectSameMeshAsReference(one, cpu::polygonizeReference(c.program, c.grid, r), 1e-4f * c.grid.cellSize, base);
      }
      o.sparseVertexTiles = true;
      for (std::uint32_t batchBricks : {0u, 9u}) {
        if (batchBricks && !c.smallBatches) continue;
        o.maxBatchBricks = batchBricks;
        vk::GpuStats st;
        const mesh::TriMesh m = vk::polygonize(device(), c.program, c.grid, o, &st);
        const std::string what = base + ", batches of " + std::to_string(batchBricks) + " bricks";
        EXPECT_EQ(st.vertexTiles, st.fieldTiles > 1 ? st.fieldTiles : 0u) << what;
        tiled += st.vertexTiles > 1 ? 1 : 0;
        expectSameBytes(m, one, what);
        // On a CPU device the host lists the tiles' vertices (vertex_tile_lists.h); the device's
        // lists (GPUs) give the same bytes.
        const bool hostLists = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU && st.vertexTiles > 1;
        EXPECT_EQ(st.hostSteps.vertexTileLists > 0.0, hostLists) << what;
        if (c.smallBatches && st.vertexTiles > 1) {  // every batching; not the legacy 256-cell grid (CI time)
          o.hostPassesOnCpuDevices = false;
          vk::GpuStats onDevice;
          expectSameBytes(vk::polygonize(device(), c.program, c.grid, o, &onDevice), one, what + ", device lists");
          EXPECT_EQ(onDevice.hostSteps.vertexTileLists, 0.0) << what;
          o.hostPassesOnCpuDevices = true;
        }
      }
    }
  }
  EXPECT_GE(tiled, 8u) << "tower and random128 at least run their vertex pass per tile";
}

}  // namespace
}  // namespace blobvk::testing
