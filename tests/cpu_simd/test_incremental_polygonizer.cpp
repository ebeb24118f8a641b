// The incremental polygonizer against full re-meshes: random edit sequences (moves, rotations,
// parameters, colours, operators, warps, added and removed children) on several scenes, and
// after every edit the spliced mesh must equal polygonizeMpu of the edited tree on the same
// grid, byte for byte (positions, normals, colours, edge keys, triangles).
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/incremental_polygonizer.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"

#include "../blobtree/random_edits.h"
#include "mesh_bytes.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace {

using namespace blobvk;

const std::string kScenes = BLOBVK_SOURCE_DIR "/scenes/";

struct Case {
  std::string scene;
  int resolution, mpuCells, threads, edits;
  friend void PrintTo(const Case& c, std::ostream* os) { *os << c.scene << " at " << c.resolution; }
};

class IncrementalMatchesFull : public ::testing::TestWithParam<Case> {};

TEST_P(IncrementalMatchesFull, AfterEveryEdit) {
  const Case c = GetParam();
  const blobtree::Scene scene = blobtree::loadScene(kScenes + c.scene);
  blobtree::EditableTree tree(scene.root);
  blobtree::GridRequest request;
  request.resolution = c.resolution;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), scene.grid, request);
  cpu::MpuOptions options;
  options.mpuCells = c.mpuCells;
  options.threads = c.threads;
  cpu::IncrementalPolygonizer inc(grid, options);
  blobvk::testing::expectSameMeshBytes(inc.reset(tree.program()), cpu::polygonizeMpu(tree.program(), grid, options), "reset");

  const glm::dvec3 lo(grid.origin), hi = lo + double(grid.cellSize) * glm::dvec3(grid.cells);
  blobvk::testing::RandomEdits edits(c.resolution * 31 + c.mpuCells, lo, hi);
  int partial = 0, changedCounts = 0;
  for (int step = 0; step < c.edits; ++step) {
    const blobtree::Edit edit = edits.next(tree.root());
    const blobtree::Region region = tree.apply(edit);
    const std::size_t before = inc.mesh().vertexCount();
    cpu::IncrementalStats st;
    const mesh::TriMesh& got = inc.update(tree.program(), region, &st);
    const mesh::TriMesh want = cpu::polygonizeMpu(tree.program(), grid, options);
    blobvk::testing::expectSameMeshBytes(got, want, c.scene + " step " + std::to_string(step) + " path " +
                                  blobtree::toString(edit.path) + " change " + std::to_string(edit.change.index()));
    if (::testing::Test::HasFailure()) return;
    partial += !st.full && st.mpusRerun < st.mpus;
    changedCounts += want.vertexCount() != before;
  }
  // The splice itself was exercised: partial updates, and some of them moved the tail.
  EXPECT_GT(partial, c.edits / 3);
  EXPECT_GT(changedCounts, c.edits / 8);
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, IncrementalMatchesFull,
    ::testing::Values(Case{"tower.json", 96, 8, 2, 40}, Case{"random128.json", 64, 8, 2, 40},
                      Case{"dice.json", 64, 6, 2, 40}, Case{"twisted_column.json", 64, 8, 2, 40},
                      Case{"tower.json", 80, 16, 1, 20}, Case{"craniotomy.json", 64, 8, 2, 30}),
    [](const auto& info) {
      std::string n = info.param.scene.substr(0, info.param.scene.find('.'));
      for (char& ch : n) if (ch == '_') ch = 'x';
      return n + "_r" + std::to_string(info.param.resolution) + "_d" + std::to_string(info.param.mpuCells) +
             "_t" + std::to_string(info.param.threads);
    });

TEST(IncrementalPolygonizer, EmptyRegionKeepsTheMeshAndUpdateNeedsAReset) {
  const blobtree::Scene scene = blobtree::loadScene(kScenes + "tower.json");
  blobtree::EditableTree tree(scene.root);
  blobtree::GridRequest request;
  request.resolution = 32;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), scene.grid, request);
  cpu::IncrementalPolygonizer inc(grid);
  EXPECT_THROW(inc.update(tree.program(), blobtree::Region{}), std::logic_error);
  const mesh::TriMesh first = inc.reset(tree.program());
  cpu::IncrementalStats st;
  blobvk::testing::expectSameMeshBytes(inc.update(tree.program(), blobtree::Region{}, &st), first, "empty region");
  EXPECT_EQ(st.mpusRerun, 0u);
  // A region covering everything re-meshes the whole grid.
  blobtree::Region all;
  all.grow(glm::dvec3(-1e30), glm::dvec3(1e30));
  blobvk::testing::expectSameMeshBytes(inc.update(tree.program(), all, &st), first, "everything");
  EXPECT_TRUE(st.full);
}

}  // namespace
