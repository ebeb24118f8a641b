// Hostile grid requests: chooseGrid must refuse them with std::invalid_argument before any
// polygonizer allocates a byte, so a typo like --resolution 1000000 cannot eat the machine.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace {

using namespace blobvk::blobtree;

// A unit-ish blob: one point primitive of support 1 (bounds about 2 units across).
Program blob() {
  Node node;
  Primitive p;
  p.type = PrimitiveType::Point;
  p.support = 1.0;
  node.kind = p;
  return compile(node);
}

std::string refusal(const Program& program, const GridSettings& scene, const GridRequest& request) {
  try {
    (void)chooseGrid(program, scene, request);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(GridLimits, AReasonableRequestGivesACoveringGrid) {
  const Program program = blob();
  GridRequest request;
  request.resolution = 64;
  const GridSpec grid = chooseGrid(program, {}, request);
  for (int a = 0; a < 3; ++a) {
    // The grid covers the bounds with a cell of margin on each side.
    EXPECT_LE(grid.origin[a], program.bounds.lo[a]);
    EXPECT_GE(grid.origin[a] + grid.cellSize * float(grid.cells[a]), program.bounds.hi[a]);
    EXPECT_LE(grid.cells[a], 64 + 3);
  }
}

TEST(GridLimits, HugeResolutionIsRefusedQuicklyWithAMessage) {
  const Program program = blob();
  for (int resolution : {1'000'000, 100'000'000, std::numeric_limits<int>::max()}) {
    GridRequest request;
    request.resolution = resolution;
    const auto start = std::chrono::steady_clock::now();
    const std::string message = refusal(program, {}, request);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_NE(message.find("too fine"), std::string::npos) << resolution << ": '" << message << "'";
    EXPECT_LT(seconds, 0.5) << "refusal must not allocate or sample anything";
  }
}

TEST(GridLimits, TinyAndNonFiniteCellSizesAreRefused) {
  const Program program = blob();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (float cell : {1e-9f, 1e-30f, 0.0f, -0.1f, nan, inf, -inf}) {
    GridRequest request;
    request.cellSize = cell;
    EXPECT_FALSE(refusal(program, {}, request).empty()) << "cell size " << cell << " accepted";
  }
  // The same values from a scene file.
  for (double cell : {1e-12, 0.0, -1.0}) {
    GridSettings scene;
    scene.cellSize = cell;
    EXPECT_FALSE(refusal(program, scene, {}).empty()) << "scene cell size " << cell << " accepted";
  }
}

TEST(GridLimits, NonPositiveResolutionIsRefused) {
  const Program program = blob();
  for (int resolution : {0, -1, std::numeric_limits<int>::min()}) {
    GridRequest request;
    request.resolution = resolution;
    EXPECT_FALSE(refusal(program, {}, request).empty()) << "resolution " << resolution << " accepted";
  }
}

TEST(GridLimits, AbsurdSceneBoundsAreRefused) {
  const Program program = blob();
  GridSettings reversed;  // lo above hi: nothing to sample
  reversed.boundsLo = Vec3(1.0);
  reversed.boundsHi = Vec3(-1.0);
  EXPECT_FALSE(refusal(program, reversed, {}).empty());

  GridSettings astronomical;  // overflows float: extent and cell size become infinite
  astronomical.boundsLo = Vec3(-1e300);
  astronomical.boundsHi = Vec3(1e300);
  EXPECT_FALSE(refusal(program, astronomical, {}).empty());

  GridSettings wide;  // finite but far too many cells for the requested cell size
  wide.boundsLo = Vec3(-1e6);
  wide.boundsHi = Vec3(1e6);
  GridRequest request;
  request.cellSize = 0.01f;
  EXPECT_NE(refusal(program, wide, request).find("too fine"), std::string::npos);
}

TEST(GridLimits, UnboundedModelAsksForSceneBounds) {
  // A bend at the root bends the whole space: the field's bounds are infinite.
  Node bend;
  Warp w;
  w.type = WarpType::Bend;
  w.factor = 0.5;
  bend.kind = w;
  Node child;
  Primitive p;
  p.support = 1.0;
  child.kind = p;
  bend.children.push_back(child);
  const Program program = compile(bend);
  if (program.bounds.finite()) GTEST_SKIP() << "compile() bounded the bend; nothing to refuse";
  EXPECT_NE(refusal(program, {}, {}).find("grid.bounds"), std::string::npos);
  GridSettings scene;  // with bounds from the scene the same model is fine
  scene.boundsLo = Vec3(-2.0);
  scene.boundsHi = Vec3(2.0);
  EXPECT_NO_THROW((void)chooseGrid(program, scene, {}));
}

TEST(GridLimits, LargestAcceptedGridCountsPointsWithoutOverflow) {
  const Program program = blob();
  GridRequest request;
  request.resolution = 60'000;  // accepted by chooseGrid; the CLI's memory check refuses it later
  const GridSpec grid = chooseGrid(program, {}, request);
  const double expected = double(grid.cells.x + 1) * double(grid.cells.y + 1) * double(grid.cells.z + 1);
  EXPECT_GT(expected, double(std::numeric_limits<std::uint32_t>::max()));
  EXPECT_EQ(double(grid.pointCount()), expected);
}

}  // namespace
