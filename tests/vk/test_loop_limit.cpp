// llvmpipe's loop limit (vk/extract/loop_limit.h): 65,535 loop iterations per shader invocation,
// after which every loop of the invocation ends silently. The sparse field pass evaluates a row of
// B + 1 points per invocation, so a blend of a few thousand points used to lose part of its field
// (2,500 points at 32 cells: 33,390 triangles instead of the reference's 39,972) with no error.
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/polygonize.h"
#include "models.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// A blend of `n` points scattered over [-10, 10]^3 (support 1.2): 2n instructions, no skip inside.
blobtree::Program blendOfPoints(int n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> at(-10.0, 10.0);
  std::vector<blobtree::Node> points;
  for (int i = 0; i < n; ++i) {
    blobtree::Node p = pointAt({at(rng), at(rng), at(rng)});
    std::get<blobtree::Primitive>(p.kind).support = 1.2;
    points.push_back(std::move(p));
  }
  return blobtree::compile(combine(blobtree::OperatorType::Blend, std::move(points)));
}

TEST(LoopLimit, BoundsFollowTheKernelsLoops) {
  const blobtree::Program program = blendOfPoints(100);
  ASSERT_EQ(program.code.size(), 200u);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  EXPECT_EQ(vk::evaluationLoopBound(program, o), 201u);  // a loop iteration per instruction, and the exit
  o.traversal = vk::Traversal::StackBased;
  EXPECT_EQ(vk::evaluationLoopBound(program, o), 402u);
  o.traversal = vk::Traversal::Auto;  // unresolved: the interpreter's
  EXPECT_EQ(vk::evaluationLoopBound(program, o), 201u);
  o.traversal = vk::Traversal::Specialised;
  o.brickTapes = true;  // tapes are interpreted
  EXPECT_EQ(vk::evaluationLoopBound(program, o), 201u);
  // A row of 17 points, each one evaluation, and the row's own loops.
  EXPECT_EQ(vk::brickFieldLoopIterations(16, 1000), 17u * 1000u + 2u * 17u + 8u);
  // 5,001 iterations a point: 17 x 5,001 is over 65,535, 9 x 5,001 is not.
  EXPECT_EQ(vk::brickCellsWithinLoopLimit(16, 5001, vk::kLlvmpipeLoopIterations), 8u);
  EXPECT_EQ(vk::brickCellsWithinLoopLimit(16, 8001, vk::kLlvmpipeLoopIterations), 4u);
  EXPECT_EQ(vk::brickCellsWithinLoopLimit(16, 3000, vk::kLlvmpipeLoopIterations), 16u);
  EXPECT_EQ(vk::brickCellsWithinLoopLimit(16, 30000, vk::kLlvmpipeLoopIterations), 0u);  // 3 x 30,000 is over
  EXPECT_EQ(vk::brickCellsWithinLoopLimit(16, 30000, ~0ull), 16u);                        // no limit
  vk::DeviceInfo info;
  info.name = "llvmpipe (LLVM 15.0.6, 256 bits)";
  EXPECT_EQ(vk::loopIterationLimit(info), vk::kLlvmpipeLoopIterations);
  info.name = "NVIDIA H100 80GB HBM3";
  EXPECT_EQ(vk::loopIterationLimit(info), ~0ull);
}

// The oracle is the CPU reference: a blend of 2,100 points (4,200 instructions, 17 x 4,201 loop
// iterations a row of bricks of 16) meshed by the interpreter and by the model's choice gives the
// reference's mesh index by index, on bricks that fit, classified once (a note says why they are
// smaller).
TEST_F(VulkanTest, LongProgramsAreMeshedOnBricksThatFitTheLoopLimit) {
  const blobtree::Program program = blendOfPoints(2100);
  const blobtree::GridSpec grid = gridAt(program, 24);
  const mesh::TriMesh ref = cpu::polygonizeReference(program, grid);
  const bool limited = vk::loopIterationLimit(device().info()) != ~0ull;
  for (vk::Traversal t : {vk::Traversal::Stackless, vk::Traversal::Auto}) {
    vk::GpuPolygonizeOptions options;
    options.traversal = t;
    options.brickCells = 16;
    std::vector<std::string> notes;
    options.phaseNote = [&notes](const std::string& n) { notes.push_back(n); };
    vk::GpuStats stats;
    const mesh::TriMesh mesh = vk::polygonize(device(), program, grid, options, &stats);
    const std::string what = vk::traversalName(t);
    expectSameMeshAsReference(mesh, ref, referenceToleranceCells(true) * grid.cellSize, what);
    if (!limited) continue;
    EXPECT_EQ(stats.brickCells, 8u) << what;
    // Why, then one classification, on bricks that fit, then the batches.
    ASSERT_EQ(notes.size(), 3u) << what;
    EXPECT_NE(notes[0].find("a row of 17 points would outrun the driver's loop limit"), std::string::npos) << notes[0];
    EXPECT_NE(notes[1].find("bricks of 8x8x8 cells"), std::string::npos) << notes[1];
  }
}

// Beyond what bricks of 2 cells fit (3 points a row), the job fails with an error naming the
// limit instead of giving a mesh whose field was cut short, and advising only what would run it:
// a program this long is interpreted whatever the traversal, so neither smaller bricks nor a
// specialised evaluator would.
TEST_F(VulkanTest, ProgramsNoBrickFitsAreRefusedWithTheLimitNamed) {
  if (vk::loopIterationLimit(device().info()) == ~0ull) GTEST_SKIP() << "this device's loops have no iteration limit";
  const blobtree::Program program = blendOfPoints(11000);  // 22,000 instructions: 3 x 22,001 > 65,535
  const blobtree::GridSpec grid = gridAt(program, 8);
  vk::GpuPolygonizeOptions options;
  options.traversal = vk::Traversal::Stackless;
  try {
    (void)vk::polygonize(device(), program, grid, options);
    FAIL() << "no error";
  } catch (const vk::VulkanError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("over this driver's limit of 65535"), std::string::npos) << message;
    EXPECT_NE(message.find("use the cpu backend (--backend cpu)"), std::string::npos) << message;
    EXPECT_EQ(message.find("--brick-cells"), std::string::npos) << message;
    EXPECT_EQ(message.find("--traversal specialised"), std::string::npos) << message;
  }
}

// The dense pipeline evaluates one point per invocation: only a program of more than 65,534
// instructions outruns the limit there, and it is refused before any work.
TEST_F(VulkanTest, TheDensePipelineRefusesProgramsOverTheLoopLimit) {
  if (vk::loopIterationLimit(device().info()) == ~0ull) GTEST_SKIP() << "this device's loops have no iteration limit";
  vk::GpuPolygonizeOptions options;
  options.sparse = false;
  options.traversal = vk::Traversal::Stackless;
  const blobtree::Program fits = blendOfPoints(2100);
  EXPECT_GT(vk::polygonize(device(), fits, gridAt(fits, 12), options).triangleCount(), 0u);
  const blobtree::Program over = blendOfPoints(33000);  // 66,000 instructions
  try {
    (void)vk::polygonize(device(), over, gridAt(over, 8), options);
    FAIL() << "no error";
  } catch (const vk::VulkanError& e) {
    EXPECT_NE(std::string(e.what()).find("field pass, over this driver's limit of 65535"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace blobvk::testing
