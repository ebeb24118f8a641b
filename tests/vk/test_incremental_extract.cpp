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
#include <set>
#include <string>
#include <utility>

namespace blobvk::testing {
namespace {

// The row splice finds a triangle's cell as the least point of its corners' edges per axis
// (vk/extract/row_splice.cpp), i.e. no triangle of the table has all three corners on one upper
// face of its cell (x = 1, y = 1 or z = 1, on edges along the other two axes).
TEST(IncrementalExtractLayout, NoMarchingCubesTriangleLiesInAnUpperFace) {
  int checked = 0;
  for (const mesh::McCase& c : mesh::marchingCubesCases())
    for (int t = 0; t < c.triangleCount; ++t) {
      for (int axis = 0; axis < 3; ++axis) {
        int onFace = 0;
        for (int v = 0; v < 3; ++v) {
          const int e = c.edges[3 * t + v];
          onFace += mesh::mcEdgeAxis(e) != axis && mesh::mcEdgeStart(e)[axis] == 1;
        }
        EXPECT_LT(onFace, 3) << "axis " << axis;
      }
      ++checked;
    }
  EXPECT_GT(checked, 500);  // every case was looked at (the table has 820 triangles)
}

// The bricks an edit forces, on 4 x 4 x 4 bricks of 16 cells: per axis those owning a point whose
// edges (vertex, refinement, normal samples) or holding a cell the region reaches; nothing for a
// region beside or below the grid.
TEST(IncrementalExtractLayout, BricksReachedByARegion) {
  blobtree::GridSpec grid;
  grid.origin = {0, 0, 0};
  grid.cellSize = 1.0f;
  grid.cells = {64, 64, 64};
  const vk::BrickGrid bricks = vk::brickGridFor(grid, 16);
  using P = std::pair<std::uint32_t, std::uint32_t>;
  const auto reached = [&](double zLo, double zHi, double x = 10, float normalStep = 1e-4f) {
    blobtree::Region r;
    r.grow({x, 10, zLo}, {x + 1, 11, zHi});
    const vk::BrickBox b = vk::bricksReached(grid, bricks, r, normalStep);
    if (!b.empty()) {  // x, y in [10, 11]: edges from points 9 .. 11 (4 .. 16 with normal samples 5 away)
      const P xy = normalStep < 1.0f ? P(0, 1) : P(0, 2);
      EXPECT_EQ(P(b.first[0], b.end[0]), xy);
      EXPECT_EQ(P(b.first[1], b.end[1]), xy);
    }
    return b.empty() ? P(0, 0) : P(b.first[2], b.end[2]);
  };
  EXPECT_EQ(reached(36.5, 37.5), P(2, 3));
  EXPECT_EQ(reached(33.5, 34.0), P(2, 3));
  EXPECT_EQ(reached(33.0, 34.0), P(2, 3));  // point 33 changes the z edge from 32, layer 2's own
  EXPECT_EQ(reached(32.5, 34.0), P(2, 3));
  EXPECT_EQ(reached(32.0, 34.0), P(1, 3));  // point 32 changes the z edge from 31 and cell 31: layer 1's
  EXPECT_EQ(reached(46.0, 47.9), P(2, 3));
  EXPECT_EQ(reached(46.0, 48.0), P(2, 4));  // point 48 is layer 3's
  EXPECT_EQ(reached(36.5, 37.5, 10, 5.0f), P(1, 3));  // normal samples 5 cells away
  EXPECT_EQ(reached(36.5, 37.5, 200), P(0, 0));  // beside the grid in x
  EXPECT_EQ(reached(-50, -40), P(0, 0));          // below it
  EXPECT_EQ(reached(60, 500), P(3, 4));           // past the top
  blobtree::Region x;  // the grid's last point (64) belongs to the last brick
  x.grow({64.0, 0.0, 0.0}, {70.0, 1.0, 1.0});
  const vk::BrickBox bx = vk::bricksReached(grid, bricks, x, 1e-4f);
  EXPECT_EQ(P(bx.first[0], bx.end[0]), P(3, 4));
  blobtree::Region all;
  all.grow(glm::dvec3(-1e30), glm::dvec3(1e30));
  EXPECT_EQ(vk::bricksReached(grid, bricks, all, 1e-4f).count(), bricks.count());
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
  const float tolerance = referenceToleranceCells(device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU) * grid.cellSize;
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

// A vertex count that changes exactly on a brick boundary at the region's edge, along each axis
// and on both sides: the margin of bricksReached has no slack to lose. A small point (support 2)
// moves from deep inside a large sphere to where its box's low (high) face lies half a cell before
// (after) grid point g, the first point of brick m along the axis; the large sphere's field at g
// is 0.46, the small point adds 0.084 there and nothing a cell further out, so g turns inside and
// the edge from g - 1 (brick m - 1's, low side) or from g (brick m's, high side) gains or loses
// its crossing. A box of bricks one point narrower on either side leaves that vertex stale.
TEST_F(IncrementalExtract, CountChangesOnTheRegionsBoundaryBrick) {
  const auto point = [](glm::dvec3 c, double support) {
    blobtree::Primitive p;
    p.a = c;
    p.support = support;
    return blobtree::Node{p, "", {}, {}};
  };
  blobtree::GridSpec grid;
  grid.origin = {-16.0f, -16.0f, -16.0f};
  grid.cellSize = 1.0f;
  grid.cells = {32, 32, 32};
  vk::GpuPolygonizeOptions options;
  options.brickCells = 4;
  options.traversal = vk::Traversal::Stackless;
  const double bigR = 10.0, r = 2.0;
  const double bigD = bigR * std::sqrt(1.0 - std::cbrt(0.46));  // the large sphere's field is 0.46 at g
  for (int axis = 0; axis < 3; ++axis)
    for (int side : {-1, +1}) {
      glm::ivec3 g(14, 14, 14);
      g[axis] = 16;  // the first point of brick 4 along the axis
      const glm::dvec3 gp = glm::dvec3(grid.origin) + glm::dvec3(g);
      glm::dvec3 out(0.0);
      out[axis] = side;  // from g away from the sphere's centre, the way the small point pushes
      const glm::dvec3 bigCentre = gp - bigD * out;
      const glm::dvec3 target = gp - (r - 0.5) * out;  // its box's face half a cell past g
      blobtree::EditableTree tree(
          blobtree::Node{blobtree::Operator{}, "", {}, {point(bigCentre, bigR), point(bigCentre, r)}});
      vk::IncrementalExtractor inc(device(), grid, options);
      const mesh::TriMesh before = inc.reset(tree.program());
      blobtree::Transform t;
      t.translate = target - bigCentre;
      const blobtree::Region region = tree.apply({{1}, blobtree::SetTransform{t}});
      vk::IncrementalGpuStats st;
      const mesh::TriMesh& got = inc.update(tree.program(), region, &st);
      const std::string what = "axis " + std::to_string(axis) + " side " + std::to_string(side);
      expectSameMeshBytes(got, vk::polygonize(device(), tree.program(), grid, inc.options()), what);
      EXPECT_FALSE(st.full) << what;
      // The boundary brick is in the box: m - 1 on the low side (the face before g), m on the high.
      EXPECT_EQ(side < 0 ? st.box.first[axis] : st.box.end[axis] - 1, side < 0 ? 3u : 4u) << what;
      // The edge the test is about gained or lost its vertex: one starting at g - 1 (low side) or
      // g (high side) along the axis, at g's other coordinates.
      std::set<std::uint64_t> a(before.edgeKeys.begin(), before.edgeKeys.end()), b(got.edgeKeys.begin(), got.edgeKeys.end());
      glm::ivec3 e = g;
      e[axis] += side < 0 ? -1 : 0;
      const std::uint64_t key = grid.edgeKey(e.x, e.y, e.z, axis);
      EXPECT_NE(a.count(key), b.count(key)) << what << ": the edge at the boundary brick kept its crossing";
      if (HasFailure()) return;
    }
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
