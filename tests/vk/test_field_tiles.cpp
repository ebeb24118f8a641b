// Spatial tape pruning of the field pass (vk/eval/field_tiles.h): the tile plan covers the grid exactly
// once and prunes real work, and tiled fields are bit for bit the untiled ones on every shipped
// scene (the pruned subtrees and primitives are exactly 0 in their tiles).
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

TEST(FieldTiles, CoverEveryPointOnceAndPruneTheTower) {
  const ShippedScene m = shipped("tower", 64);
  vk::FieldTilingOptions options;
  options.maxTiles = 12;
  const auto tiles = vk::planFieldTiles(m.program, m.grid, options);
  ASSERT_GT(tiles.size(), 1u);
  ASSERT_LE(tiles.size(), 12u);
  const auto pts = m.grid.points();
  std::vector<int> hits(m.grid.pointCount(), 0);
  double work = 0.0;
  for (const auto& t : tiles) {
    for (int a = 0; a < 3; ++a) ASSERT_LE(t.first[std::size_t(a)], t.last[std::size_t(a)]);
    for (std::uint32_t k = t.first[2]; k <= t.last[2]; ++k)
      for (std::uint32_t j = t.first[1]; j <= t.last[1]; ++j)
        for (std::uint32_t i = t.first[0]; i <= t.last[0]; ++i) ++hits[m.grid.pointIndex(int(i), int(j), int(k))];
    work += double(t.points()) * t.cost;
  }
  EXPECT_TRUE(std::all_of(hits.begin(), hits.end(), [](int h) { return h == 1; }));
  // The tower's storeys are apart: pruning must remove most of the work (the whole-grid cost
  // counts every primitive).
  const double whole = double(m.grid.pointCount()) * vk::prunedEvaluationCost(m.program, {});
  EXPECT_LT(work, 0.5 * whole);
  EXPECT_EQ(pts.x * pts.y * pts.z, std::int64_t(m.grid.pointCount()));
}

TEST(FieldTiles, OneTileWhenAskedAndTheSamePlanEveryTime) {
  const ShippedScene m = shipped("random128", 48);
  vk::FieldTilingOptions one;
  one.maxTiles = 1;
  EXPECT_EQ(vk::planFieldTiles(m.program, m.grid, one).size(), 1u);
  const auto a = vk::planFieldTiles(m.program, m.grid), b = vk::planFieldTiles(m.program, m.grid);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].first, b[i].first);
    EXPECT_EQ(a[i].last, b[i].last);
  }
}

TEST(FieldTiles, PrunedCodeDropsPrimitivesAndSubtreesOutsideTheRegion) {
  const ShippedScene m = shipped("tower", 32);
  vk::PointRegion far;
  far.valid = true;
  for (int a = 0; a < 3; ++a) far.lo[a] = 1e6f, far.hi[a] = 1e6f + 1.0f;
  vk::CodegenOptions c;
  c.region = far;
  const std::string pruned = vk::generateSpecialisedEvaluator(m.program, c);
  EXPECT_EQ(pruned.find("wyvill("), std::string::npos);  // no primitive is evaluated
  EXPECT_EQ(vk::prunedEvaluationCost(m.program, far), 0u);
  const std::string whole = vk::generateSpecialisedEvaluator(m.program, {});
  EXPECT_NE(whole.find("wyvill("), std::string::npos);
}

// A Ricci blend of random points (power 8): each child is a primitive, its pow, and the add.
blobtree::Program ricciBlend(int points) { return blobtree::compile(blobtree::generateRandomRicciBlobs(points, 11, 8.0)); }

// A small region around the centre of the program's first primitive's box: it meets that
// primitive and a few of its neighbours.
vk::PointRegion regionAroundFirstPrimitive(const blobtree::Program& program) {
  const auto& box = program.primitiveBoxes[0];
  vk::PointRegion near;
  near.valid = true;
  for (int a = 0; a < 3; ++a) {
    const float c = 0.5f * ((&box.lo.x)[a] + (&box.hi.x)[a]);
    near.lo[a] = c - 0.05f, near.hi[a] = c + 0.05f;
  }
  return near;
}

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// llvmpipe's pow costs tens of primitives: the pruned code leaves out the pow of every child it
// prunes (powField(0, e) is 0), and the cost that plans the tiles counts it so.
TEST(FieldTiles, PrunedRicciChildrenLeaveTheirPowOut) {
  const blobtree::Program program = ricciBlend(24);
  std::size_t pows = 0;
  for (const auto& in : program.code) pows += (in.code.x & 0xffu) == layout::OP_POW;
  ASSERT_EQ(pows, 25u);  // one per child and the root
  // Unrolled, the field and the colour evaluators (the gradient's vertex code is not pruned here).
  vk::CodegenOptions c;
  c.loops.enabled = false;
  c.gradient = false;
  EXPECT_EQ(occurrences(vk::generateSpecialisedEvaluator(program, c), "powField("), 2 * 25u);
  // A region around the first child's centre: the children whose boxes it meets keep their pow.
  const vk::PointRegion near = regionAroundFirstPrimitive(program);
  std::size_t kept = 0;
  for (const auto& b : program.primitiveBoxes) kept += !vk::regionMissesBox(near, b);
  ASSERT_GE(kept, 1u);
  ASSERT_LT(kept, 24u);
  c.region = near;
  EXPECT_EQ(occurrences(vk::generateSpecialisedEvaluator(program, c), "powField("), 2 * (kept + 1));
  // Each kept child its primitive, its pow and (past the first) its add; each run of pruned
  // children one add of 0; the root's pow; the blend's box test.
  std::uint32_t expected = vk::kPowCost + 1;
  bool inRun = false;
  for (std::size_t i = 0; i < 24; ++i) {
    const bool pruned = vk::regionMissesBox(near, program.primitiveBoxes[i]);
    if (!pruned) expected += vk::kPrimitiveCost + vk::kPowCost + (i > 0 ? 1 : 0);
    if (pruned && i > 0 && !inRun) ++expected;
    inRun = pruned && i > 0;
  }
  ASSERT_FALSE(vk::regionMissesBox(near, program.primitiveBoxes[0]));
  EXPECT_EQ(vk::prunedEvaluationCost(program, near), expected);
}

// A flat blend pruned to a region: each run of children that are 0 there is one addition of 0 in
// the generated code (the bits of adding each), so a tile of a blend of hundreds of points unrolls.
TEST(FieldTiles, PrunedBlendChildrenFoldIntoOneAdditionPerRun) {
  const blobtree::Program program = blobtree::compile(blobtree::generateRandomBlobs(24, 11));
  const vk::PointRegion near = regionAroundFirstPrimitive(program);
  // The blend's box test, the first child, two per kept child after it, one per run of pruned ones.
  std::uint32_t expected = 2, runs = 0;
  bool inRun = false;
  for (std::size_t i = 1; i < 24; ++i) {
    const bool pruned = vk::regionMissesBox(near, program.primitiveBoxes[i]);
    expected += pruned ? (inRun ? 0 : 1) : 2;
    runs += pruned && !inRun;
    inRun = pruned;
  }
  ASSERT_GT(runs, 0u);
  EXPECT_EQ(vk::prunedInstructionCount(program, near), expected);
  EXPECT_EQ(vk::branchedInstructionCount(program, near), program.code.size()) << "looped code runs them all";
  vk::CodegenOptions c;
  c.loops.enabled = false;
  c.gradient = false;
  c.region = near;
  // In the field and the colour evaluators; the colour's blend repeated to its fixed point in a loop.
  const std::string code = vk::generateSpecialisedEvaluator(program, c);
  EXPECT_EQ(occurrences(code, "+ 0.0;  // pruned: children"), 2 * runs);
  EXPECT_EQ(occurrences(code, "for (uint k = 0u; k < "), runs);
}

// The same Ricci blend, tiled: its field is the untiled one bit for bit (a left-out pow was an
// exact 0) and the CPU reference's within float noise (llvmpipe's pow is not the C library's).
TEST_F(VulkanTest, TiledRicciBlendEqualsTheUntiledFieldBitForBit) {
  const blobtree::Program program = ricciBlend(24);
  const blobtree::GridSpec grid = gridAt(program, 40);
  vk::FieldOptions untiled;
  untiled.traversal = vk::Traversal::Specialised;
  untiled.tiling.maxTiles = 1;
  vk::FieldOptions tiled = untiled;
  tiled.tiling.maxTiles = 16;
  tiled.tiling.minGain = 0.0;
  vk::FieldStats stats;
  const auto a = vk::evaluateFieldOnGrid(device(), program, grid, untiled);
  const auto b = vk::evaluateFieldOnGrid(device(), program, grid, tiled, &stats);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_GT(stats.tiles, 1u);
  EXPECT_LT(maxFieldDifference(b, referenceField(program, grid)), 1e-5f);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0);
}

class TiledFieldTest : public VulkanTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(TiledFieldTest, EqualsTheUntiledFieldBitForBit) {
  const ShippedScene m = shipped(GetParam(), 40);
  vk::FieldOptions untiled;
  untiled.traversal = vk::Traversal::Specialised;
  untiled.tiling.maxTiles = 1;
  vk::FieldOptions tiled;
  tiled.traversal = vk::Traversal::Specialised;
  tiled.tiling.maxTiles = 16;
  tiled.tiling.minGain = 0.0;  // as many tiles as the plan can make
  vk::FieldStats stats;
  const auto a = vk::evaluateFieldOnGrid(device(), m.program, m.grid, untiled);
  const auto b = vk::evaluateFieldOnGrid(device(), m.program, m.grid, tiled, &stats);
  ASSERT_EQ(a.size(), b.size());
  // The oracle is the scalar CPU reference; bit equality with the untiled run then shows that
  // pruning drops only exact zeros.
  EXPECT_LT(maxFieldDifference(b, referenceField(m.program, m.grid)), 1e-5f) << GetParam();
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << GetParam();
  // (large programs: LargeProgramIsSpecialisedPerTile)
  if (vk::canSpecialise(m.program, {}, vk::defaultCodegenOptions(device()).loops)) {
    EXPECT_EQ(stats.tiles, vk::planFieldTiles(m.program, m.grid, tiled.tiling).size()) << GetParam();
  }
  if (GetParam() == "tower" || GetParam() == "random128") {
    EXPECT_GT(stats.tiles, 1u) << "these scenes have primitives far apart";
  }
}

// A program too large to unroll whole (tower_L6P8I4: 6,448 instructions) is unrolled per tile
// where the pruned code fits; its field stays that of the interpreter, within float noise (the
// interpreter and the generated code may contract multiply-adds differently). Unrolled code is
// asked for: by default the whole program would be looped (vk/eval/program_shape.h).
TEST_F(VulkanTest, LargeProgramIsSpecialisedPerTile) {
  const ShippedScene m = shipped("tower_L6P8I4", 40);
  vk::CodegenOptions unrolled = vk::defaultCodegenOptions(device());
  unrolled.loops.enabled = false;
  const vk::LoopOptions loops = unrolled.loops;
  ASSERT_FALSE(vk::canSpecialise(m.program, {}, loops));
  vk::FieldTilingOptions many;
  many.maxTiles = 16;
  many.minGain = 0.0;
  many.minPointsForLargePrograms = 0;
  const auto tiles = vk::planFieldTiles(m.program, m.grid, many);
  const auto fits = std::count_if(tiles.begin(), tiles.end(),
                                  [&](const vk::FieldTile& t) { return vk::specialiseTile(m.program, t.region, loops); });
  EXPECT_GT(fits, 0) << "no tile prunes the program under the limit";
  vk::FieldOptions interpreter;
  interpreter.traversal = vk::Traversal::Stackless;
  const auto a = vk::evaluateFieldOnGrid(device(), m.program, m.grid, interpreter);
  vk::FieldStats stats;
  vk::FieldOptions specialised;
  specialised.traversal = vk::Traversal::Specialised;
  specialised.codegen = &unrolled;
  vk::evaluateFieldOnGrid(device(), m.program, m.grid, specialised, &stats);
  EXPECT_EQ(stats.tiles, 1u) << "a small grid is not worth building large tile kernels";
  vk::FieldOptions tiled;
  tiled.traversal = vk::Traversal::Specialised;
  tiled.codegen = &unrolled;
  tiled.tiling = many;
  const auto b = vk::evaluateFieldOnGrid(device(), m.program, m.grid, tiled);
  ASSERT_EQ(a.size(), b.size());
  const auto cpu = referenceField(m.program, m.grid);
  EXPECT_LT(maxFieldDifference(b, cpu), 1e-5f) << "tiled, specialised per tile";
  EXPECT_LT(maxFieldDifference(a, cpu), 1e-5f) << "interpreter";
}

INSTANTIATE_TEST_SUITE_P(Shipped, TiledFieldTest, ::testing::ValuesIn(shippedSceneNames()),
                         [](const auto& info) { return info.param; });

// The vertex pass runs per tile with the evaluator pruned to the tile's vertices (a cell and a
// normal step beyond its points): the mesh is the CPU reference mesh, and bit for bit the
// untiled one. tower_L6P8I4 is left out rather than skipped: its vertices run the interpreter
// either way (its tiles are too large to specialise), 40 s here for nothing the field test does
// not cover.
class TiledMeshTest : public VulkanTest, public ::testing::WithParamInterface<std::string> {};

std::vector<std::string> scenesWithSpecialisableTiles() {
  std::vector<std::string> names = shippedSceneNames();
  std::erase(names, std::string("tower_L6P8I4"));
  return names;
}

TEST_P(TiledMeshTest, TiledPolygonizationEqualsUntiledBitForBit) {
  const ShippedScene m = shipped(GetParam(), 36);
  vk::GpuPolygonizeOptions untiled;
  untiled.traversal = vk::Traversal::Specialised;
  untiled.maxFieldTiles = 1;
  untiled.sparse = false;  // the tiles are the dense pipeline's
  untiled.refineSteps = 2;  // the refinement evaluates along the edge too
  vk::GpuPolygonizeOptions tiled = untiled;
  tiled.maxFieldTiles = 8;
  tiled.tiledVertexPass = true;
  vk::GpuStats stats;
  const mesh::TriMesh a = vk::polygonize(device(), m.program, m.grid, untiled);
  const mesh::TriMesh b = vk::polygonize(device(), m.program, m.grid, tiled, &stats);
  ASSERT_GT(a.triangleCount(), 0u);
  cpu::ReferenceOptions reference;
  reference.refineSteps = untiled.refineSteps;
  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  expectSameMeshAsReference(b, cpu::polygonizeReference(m.program, m.grid, reference),
                            referenceToleranceCells(lavapipe) * m.grid.cellSize, GetParam() + " tiled");
  EXPECT_EQ(a.edgeKeys, b.edgeKeys) << GetParam();
  EXPECT_EQ(a.triangles, b.triangles) << GetParam();
  auto same = [](const auto& x, const auto& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
  };
  EXPECT_TRUE(same(a.positions, b.positions)) << GetParam();
  EXPECT_TRUE(same(a.normals, b.normals)) << GetParam();
  EXPECT_TRUE(same(a.colours, b.colours)) << GetParam();
  if (GetParam() == "tower" || GetParam() == "random128") {
    EXPECT_GT(stats.fieldTiles, 1u);
  }
}

INSTANTIATE_TEST_SUITE_P(Shipped, TiledMeshTest, ::testing::ValuesIn(scenesWithSpecialisableTiles()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace blobvk::testing
