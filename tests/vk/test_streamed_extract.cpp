// The sparse extraction handed to a mesh sink batch by batch (vk/extract/streamed_extract.h): the
// runs joined are the CPU reference's mesh index by index, every triangle's corners lie in the
// window it comes with, and the host never holds more than two batches' vertices.
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/vk/extract/streamed_extract.h"
#include "joining_sink.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace blobvk::testing {
namespace {

TEST_F(VulkanTest, StreamedBatchesJoinToTheReferenceMesh) {
  for (const auto& [name, keyed] : {std::pair{"tower", false}, {"dice", false}, {"twisted_column", false}, {"tower", true},
                                     {"twisted_column", true}}) {
    SCOPED_TRACE(keyed ? "one brick layer a batch, keyed corners" : "batches of brick layers");
    const auto scene = shipped(name, 64);
    cpu::ReferenceOptions ro;
    const mesh::TriMesh reference = cpu::polygonizeReference(scene.program, scene.grid, ro);
    vk::GpuPolygonizeOptions options;
    options.brickCells = 4;      // many bricks ...
    options.maxBatchBricks = 64;  // ... in many batches, each a few brick layers
    options.keyedCornerBatches = keyed;  // or each one layer, its triangles matched by key
    JoiningSink sink;
    std::size_t lastDone = 0, total = 0;
    vk::GpuStats stats;
    vk::polygonizeStreamed(device(), scene.program, scene.grid, options, sink, &stats,
                           [&](std::size_t done, std::size_t n) { lastDone = done, total = n; });
    ASSERT_GE(stats.batches, 4u) << name;
    EXPECT_EQ(lastDone, total) << name;
    EXPECT_EQ(total, stats.batches) << name;
    EXPECT_LT(sink.largestWindow, reference.positions.size()) << name << ": a window as large as the mesh";
    // The reference's topology index by index, its positions to docs/vulkan.md's tolerance, and
    // the in-memory extraction's bytes (one batch).
    mesh::TriMesh referenceRuns = reference;
    referenceRuns.edgeKeys.clear();  // a sink gets no edge keys
    expectSameMeshAsReference(sink.mesh, referenceRuns, 1e-4f * scene.grid.cellSize, name);
    vk::GpuPolygonizeOptions whole = options;
    whole.maxBatchBricks = 0;
    whole.keyedCornerBatches = false;
    expectJoinedRuns(sink, stats.batches, vk::polygonize(device(), scene.program, scene.grid, whole), name);
  }
}

TEST_F(VulkanTest, StreamingNeedsTheSparseExtraction) {
  const auto scene = shipped("tower", 32);
  vk::GpuPolygonizeOptions options;
  options.sparse = false;
  JoiningSink sink;
  EXPECT_THROW(vk::polygonizeStreamed(device(), scene.program, scene.grid, options, sink), std::runtime_error);
  EXPECT_EQ(sink.vertexRuns, 0u);
}

}  // namespace
}  // namespace blobvk::testing
