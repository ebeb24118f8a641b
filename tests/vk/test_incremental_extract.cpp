// Incremental re-extraction on Vulkan (vk/extract/incremental_extract.h) against full runs:
// random edit sequences (moves, rotations, parameters, colours, operators, warps, added and
// removed children) on several scenes; after every edit the spliced mesh must equal a full
// vk::polygonize of the edited tree byte for byte, and the CPU reference polygonizer (the
// independent oracle) index by index: the same edge keys and triangles, positions within the
// GPU's documented tolerance.
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/mesh/marching_cubes.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "../blobtree/random_edits.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "mesh_bytes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>

namespace blobvk::testing {
namespace {

// The per-layer split assumes a triangle's cell is the least point layer of its corners' edges,
// i.e. no triangle of the table has all three corners on its cell's top face (z = 1, x/y edges).
TEST(IncrementalExtractLayout, NoMarchingCubesTriangleLiesInTheTopFace) {
  int checked = 0;
  for (const mesh::McCase& c : mesh::marchingCubesCases())
    for (int t = 0; t < c.triangleCount; ++t) {
      int onTop = 0;
      for (int v = 0; v < 3; ++v) {
        const int e = c.edges[3 * t + v];
        onTop += mesh::mcEdgeAxis(e) != 2 && mesh::mcEdgeStart(e)[2] == 1;
      }
      EXPECT_LT(onTop, 3);
      ++checked;
    }
  EXPECT_GT(checked, 500);  // every case was looked at (the table has 820 triangles)
}

// The layers an edit forces, on 4 layers of 16 cells: those holding the points, edges and cells
// the region reaches, and the one below when a vertex of its top point layer's neighbour (the
// first point layer of the next) may change; nothing for a region beside or below the grid.
TEST(IncrementalExtractLayout, LayersReachedByARegion) {
  blobtree::GridSpec grid;
  grid.origin = {0, 0, 0};
  grid.cellSize = 1.0f;
  grid.cells = {64, 64, 64};
  const auto layers = [&](double zLo, double zHi, double x = 10, float normalStep = 1e-4f) {
    blobtree::Region r;
    r.grow({x, 10, zLo}, {x + 1, 11, zHi});
    const vk::LayerRange l = vk::layersReached(grid, 16, 4, r, normalStep);
    return std::pair<std::uint32_t, std::uint32_t>{l.first, l.end};
  };
  using P = std::pair<std::uint32_t, std::uint32_t>;
  EXPECT_EQ(layers(36.5, 37.5), P(2, 3));
  EXPECT_EQ(layers(33.5, 34.0), P(2, 3));  // edges from point 32 (layer 2's first) keep their vertices
  EXPECT_EQ(layers(33.0, 34.0), P(1, 3));  // point 33 changes the z edge from 32: layer 1 names it
  EXPECT_EQ(layers(46.0, 47.9), P(2, 3));
  EXPECT_EQ(layers(46.0, 48.0), P(2, 4));  // point 48 is layer 3's
  EXPECT_EQ(layers(36.5, 37.5, 10, 5.0f), P(1, 3));  // normal samples 5 cells away
  EXPECT_EQ(layers(36.5, 37.5, 200), P(0, 0));  // beside the grid in x
  EXPECT_EQ(layers(-50, -40), P(0, 0));          // below it
  EXPECT_EQ(layers(60, 500), P(3, 4));       // past the top
  blobtree::Region all;
  all.grow(glm::dvec3(-1e30), glm::dvec3(1e30));
  const vk::LayerRange l = vk::layersReached(grid, 16, 4, all, 1e-4f);
  EXPECT_EQ(P(l.first, l.end), P(0, 4));
}

struct Case {
  std::string scene;
  int resolution;
  std::uint32_t brickCells, maxBatchBricks;
  int edits;
  // Scenes of many small parts (most random edits reach a few layers): the splice must have run
  // partial updates that changed counts and moved a tail. Elsewhere (a twist above everything,
  // a few large parts) at least one update must have been partial.
  bool localEdits;
  // Auto: each run takes the cost model's evaluator (small programs build specialised code per
  // edit, which the byte comparisons then hold against full runs that may interpret).
  vk::Traversal traversal = vk::Traversal::Stackless;
  friend void PrintTo(const Case& c, std::ostream* os) { *os << c.scene << " at " << c.resolution; }
};

class IncrementalExtractMatchesFull : public VulkanTest, public ::testing::WithParamInterface<Case> {};

TEST_P(IncrementalExtractMatchesFull, AfterEveryEdit) {
  const Case c = GetParam();
  const blobtree::Scene scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + c.scene + ".json");
  blobtree::EditableTree tree(scene.root);
  blobtree::GridRequest request;
  request.resolution = c.resolution;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), scene.grid, request);
  vk::GpuPolygonizeOptions options;
  options.brickCells = c.brickCells;
  options.maxBatchBricks = c.maxBatchBricks;
  options.traversal = c.traversal;
  vk::IncrementalExtractor inc(device(), grid, options);
  const float tolerance = referenceToleranceCells(true) * grid.cellSize;
  const auto check = [&](const mesh::TriMesh& got, const std::string& what) {
    expectSameMeshBytes(got, vk::polygonize(device(), tree.program(), grid, inc.options()), what + " (full vk)");
    const mesh::TriMesh ref = cpu::polygonizeReference(tree.program(), grid);
    if (ref.triangleCount() > 0) expectSameMeshAsReference(got, ref, tolerance, what + " (CPU reference)");
    else EXPECT_EQ(got.triangleCount(), 0u) << what;
  };
  vk::IncrementalGpuStats st;
  check(inc.reset(tree.program(), &st), c.scene + " reset");
  EXPECT_TRUE(st.full);
  ASSERT_GT(st.layers, 3u) << "too few layers to test a partial re-run";

  const glm::dvec3 lo(grid.origin), hi = lo + double(grid.cellSize) * glm::dvec3(grid.cells);
  RandomEdits edits(c.resolution * 37 + c.brickCells, lo, hi);
  int partial = 0, changedCounts = 0, movedTail = 0;
  for (int step = 0; step < c.edits; ++step) {
    const blobtree::Edit edit = edits.next(tree.root());
    const blobtree::Region region = tree.apply(edit);
    const std::size_t before = inc.mesh().vertexCount();
    const mesh::TriMesh& got = inc.update(tree.program(), region, &st);
    check(got, c.scene + " step " + std::to_string(step) + " path " + blobtree::toString(edit.path) + " change " +
                   std::to_string(edit.change.index()) + " layers " + std::to_string(st.firstLayer) + "+" +
                   std::to_string(st.layersRerun));
    if (::testing::Test::HasFailure()) return;
    partial += !st.full && st.layersRerun > 0 && st.layersRerun < st.layers;
    changedCounts += got.vertexCount() != before;
    movedTail += st.verticesMoved > 0 && st.trianglesMoved > 0;
  }
  EXPECT_GT(partial, 0);
  if (c.localEdits) {
    EXPECT_GT(partial, c.edits / 3);
    EXPECT_GT(changedCounts, c.edits / 8);
    EXPECT_GT(movedTail, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, IncrementalExtractMatchesFull,
                         ::testing::Values(Case{"tower", 48, 4, 0, 14, true}, Case{"random128", 28, 4, 0, 5, true},
                                           Case{"dice", 40, 4, 0, 10, false},
                                           Case{"twisted_column", 40, 4, 0, 8, false, vk::Traversal::Auto},
                                           Case{"craniotomy", 40, 4, 7, 8, false, vk::Traversal::Auto}),
                         [](const auto& info) {
                           std::string n = info.param.scene;
                           for (char& ch : n) if (ch == '_') ch = 'x';
                           return n + "_r" + std::to_string(info.param.resolution) + "_b" +
                                  std::to_string(info.param.brickCells) +
                                  (info.param.maxBatchBricks ? "_batches" : "") +
                                  (info.param.traversal == vk::Traversal::Auto ? "_auto" : "");
                         });

class IncrementalExtract : public VulkanTest {};

// The region's edges, where an edit's change is smallest (its kernel's last few bits): a large
// sphere whose top and bottom caps just cross the support of a small point above and below it.
// Nudging a small point changes the vertices of the cap's crossing edges by a few bits, right at
// its region's lowest (top point) or highest (bottom point) rows of points. The scene slides
// through one brick layer of a fixed grid in quarter cells, so the region's edges meet every
// position against the layer boundaries: a first or last layer chosen too late or too early
// leaves stale vertices.
TEST_F(IncrementalExtract, ChangesAtTheRegionsEdgesAreKept) {
  const auto point = [](double z, double support) {
    blobtree::Primitive p;
    p.a = {0.0, 0.0, z};
    p.support = support;
    return blobtree::Node{p, "", {}, {}};
  };
  blobtree::GridSpec grid;
  grid.origin = {-16.0f, -16.0f, -16.0f};
  grid.cellSize = 1.0f;
  grid.cells = {32, 32, 32};
  vk::GpuPolygonizeOptions options;
  options.brickCells = 4;
  options.traversal = vk::Traversal::Stackless;  // a kernel build per nudge would only add time
  const double R = 20.0, r = 3.0, cap = R * std::sqrt(1.0 - std::cbrt(0.5));  // the big surface: z = +-9.08
  int partial = 0, changed = 0;
  for (int quarter = 0; quarter < 4 * 4; ++quarter) {
    const double shift = 0.25 * quarter;
    // The small supports end 0.1 past the caps, inside the big sphere.
    blobtree::Node root{blobtree::Operator{}, "", {},
                        {point(shift, R), point(shift + cap + r - 0.1, r), point(shift - cap - r + 0.1, r)}};
    blobtree::EditableTree tree(root);
    vk::IncrementalExtractor inc(device(), grid, options);
    inc.reset(tree.program());
    for (std::size_t child : {1, 2}) {
      const mesh::TriMesh before = inc.mesh();
      blobtree::Transform t;
      t.translate = {0.0, 0.0, child == 1 ? 0.03 : -0.03};  // away from the caps
      const blobtree::Region region = tree.apply({{child}, blobtree::SetTransform{t}});
      vk::IncrementalGpuStats st;
      const mesh::TriMesh& got = inc.update(tree.program(), region, &st);
      expectSameMeshBytes(got, vk::polygonize(device(), tree.program(), grid, inc.options()),
                      "shift " + std::to_string(shift) + " child " + std::to_string(child) + " layers " +
                          std::to_string(st.firstLayer) + "+" + std::to_string(st.layersRerun));
      if (HasFailure()) return;
      partial += !st.full && st.layersRerun < st.layers;
      changed += !sameBytes(got.positions, before.positions);
    }
  }
  EXPECT_EQ(partial, 2 * 16);
  EXPECT_EQ(changed, 2 * 16);  // every nudge reached the caps' vertices
}

TEST_F(IncrementalExtract, EmptyRegionKeepsTheMeshAndUpdateNeedsAReset) {
  const ShippedScene s = shipped("tower", 32);
  vk::GpuPolygonizeOptions options;
  options.brickCells = 4;
  vk::IncrementalExtractor inc(device(), s.grid, options);
  EXPECT_THROW(inc.update(s.program, blobtree::Region{}), std::logic_error);
  const mesh::TriMesh first = inc.reset(s.program);
  ASSERT_GT(first.triangleCount(), 100u);
  vk::IncrementalGpuStats st;
  expectSameMeshBytes(inc.update(s.program, blobtree::Region{}, &st), first, "empty region");
  EXPECT_EQ(st.layersRerun, 0u);
  blobtree::Region all;
  all.grow(glm::dvec3(-1e30), glm::dvec3(1e30));
  expectSameMeshBytes(inc.update(s.program, all, &st), first, "everything");
  EXPECT_TRUE(st.full);
  // A region in the middle of the unchanged program re-runs a few layers and keeps the bytes.
  const blobtree::GridSpec& g = s.grid;
  const glm::dvec3 mid = glm::dvec3(g.origin) + 0.5 * double(g.cellSize) * glm::dvec3(g.cells);
  blobtree::Region middle;
  middle.grow(mid, mid + glm::dvec3(g.cellSize));
  expectSameMeshBytes(inc.update(s.program, middle, &st), first, "middle");
  EXPECT_FALSE(st.full);
  EXPECT_GT(st.layersRerun, 0u);
  EXPECT_LT(st.layersRerun, st.layers);
}

TEST_F(IncrementalExtract, RefusesTheDensePath) {
  const ShippedScene s = shipped("tower", 16);
  vk::GpuPolygonizeOptions options;
  options.sparse = false;
  EXPECT_THROW(vk::IncrementalExtractor(device(), s.grid, options), vk::VulkanError);
}

}  // namespace
}  // namespace blobvk::testing
