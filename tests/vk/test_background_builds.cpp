// A job that would wait for its slowest kernel instead runs the embedded interpreter and leaves the
// kernel to build in the background for the jobs after it (Device::buildInBackground,
// GpuPolygonizeOptions::interpretVertexPassUntilBuilt): the builds run once per key and are
// waited for, jobs interpret until the build has finished, the meshes are the generated kernel's
// byte for byte (so are those of the vertex pass per field tile, whose kernels a job expected to
// run again builds once it has run the generated kernel), and the cost model asks for it only
// where one interpreted vertex pass is predicted to cost less than the build.
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/polygonize.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "unrolled_code.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>

namespace blobvk::testing {
namespace {

class BackgroundBuildTest : public VulkanTest {};

TEST_F(BackgroundBuildTest, RunOncePerKeyAndAreWaitedFor) {
  vk::Device fresh(device().host());  // its own kernel cache, so nothing is built yet
  const std::uint32_t spec[1] = {64};
  std::atomic<int> runs{0};
  fresh.buildInBackground("reduce", [&] {
    fresh.kernel("scan_reduce", spec);
    ++runs;
  });
  fresh.buildInBackground("reduce", [&] { ++runs; });  // the key was started: ignored
  fresh.buildInBackground("fails", [] { throw std::runtime_error("a failed build is dropped"); });
  EXPECT_TRUE(fresh.backgroundBuildStarted("reduce"));
  EXPECT_FALSE(fresh.backgroundBuildStarted("apply"));
  EXPECT_TRUE(fresh.waitForBackgroundBuild("reduce"));
  EXPECT_TRUE(fresh.backgroundBuildDone("reduce"));
  EXPECT_FALSE(fresh.backgroundBuildDone("apply"));  // never started
  EXPECT_NE(fresh.findKernel("scan_reduce", spec), nullptr);  // built into the cache
  EXPECT_FALSE(fresh.waitForBackgroundBuild("apply"));
  fresh.waitForBackgroundBuilds();
  EXPECT_EQ(runs.load(), 1);
  EXPECT_EQ(fresh.backgroundBuildsStarted(), 2u);
  // A held build does not begin until released; waiting for it releases it.
  fresh.holdBackgroundBuilds(true);
  fresh.buildInBackground("held", [&] { ++runs; });
  EXPECT_FALSE(fresh.backgroundBuildDone("held"));
  EXPECT_EQ(runs.load(), 1);
  EXPECT_TRUE(fresh.waitForBackgroundBuild("held"));
  EXPECT_TRUE(fresh.backgroundBuildDone("held"));
  EXPECT_EQ(runs.load(), 2);
}

struct Job {
  mesh::TriMesh mesh;
  vk::GpuStats stats;
};

Job polygonizeOn(vk::Device& d, const blobtree::Program& program, const blobtree::GridSpec& grid,
                 bool interpretUntilBuilt, std::uint32_t expectedRuns) {
  // The generated gradient, unrolled (a small program) on every driver; given, so that the stats
  // report it.
  const vk::CodegenOptions codegen = unrolledCodegen(d);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Specialised;
  o.codegen = &codegen;
  o.interpretVertexPassUntilBuilt = interpretUntilBuilt;
  o.expectedRuns = expectedRuns;
  Job j;
  j.mesh = vk::polygonize(d, program, grid, o, &j.stats);
  return j;
}

TEST_F(BackgroundBuildTest, FirstJobInterpretsTheVertexPassAndTheNextRunsTheGeneratedKernel) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 48);
  // The oracle: the generated gradient's kernel, built before the job as the default path does.
  vk::Device reference(device().host());
  const Job generated = polygonizeOn(reference, program, grid, false, 1);
  ASSERT_TRUE(generated.stats.vertexGradient);
  ASSERT_FALSE(generated.mesh.triangles.empty());
  EXPECT_EQ(reference.backgroundBuildsStarted(), 0u);

  // The interpreted gradient gives the generated code's bytes on lavapipe; other drivers round
  // sin, cos and pow otherwise in the two code shapes (docs/vulkan.md).
  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  const float cell = grid.cellSize;
  auto expectInterpretedMesh = [&](const mesh::TriMesh& m, const std::string& what) {
    if (lavapipe) {
      expectSameBytes(m, generated.mesh, what);
    } else {
      expectSameMeshWithin(m, generated.mesh, 1e-2f * cell, 1e-2f, 1e-3f, what);
    }
  };
  vk::Device fresh(device().host());
  fresh.holdBackgroundBuilds(true);  // the builds cannot finish before the second job
  const Job first = polygonizeOn(fresh, program, grid, true, 3);
  EXPECT_FALSE(first.stats.vertexGradient);  // interpreted
  ASSERT_GT(first.stats.fieldTiles, 1u);
  // The generated kernel's build, started with the job; the field tiles' vertex kernels', started
  // once it was done (not before: they would slow it).
  EXPECT_EQ(fresh.backgroundBuildsStarted(), 2u);
  expectInterpretedMesh(first.mesh, "first job, interpreted vertex pass");
  // The builds still run: the second job interprets again, neither waiting for them nor starting
  // more.
  const Job second = polygonizeOn(fresh, program, grid, true, 3);
  EXPECT_FALSE(second.stats.vertexGradient);
  EXPECT_EQ(fresh.backgroundBuildsStarted(), 2u);
  expectInterpretedMesh(second.mesh, "second job, the builds unfinished");
  // Once they have finished, the next job runs the generated kernels, per field tile.
  fresh.waitForBackgroundBuilds();
  const Job third = polygonizeOn(fresh, program, grid, true, 3);
  EXPECT_TRUE(third.stats.vertexGradient);
  EXPECT_EQ(third.stats.vertexTiles, third.stats.fieldTiles);
  EXPECT_EQ(fresh.backgroundBuildsStarted(), 2u);
  expectSameBytes(third.mesh, generated.mesh, "third job, the tiles' generated kernels");
  // A job that finds the one generated kernel built runs it, and leaves the tiles' to build.
  vk::Device other(device().host());
  const Job untiled = polygonizeOn(other, program, grid, false, 3);
  EXPECT_TRUE(untiled.stats.vertexGradient);
  EXPECT_EQ(untiled.stats.vertexTiles, 0u);
  EXPECT_EQ(other.backgroundBuildsStarted(), 1u);
  other.waitForBackgroundBuilds();
  const Job tiled = polygonizeOn(other, program, grid, false, 3);
  EXPECT_EQ(tiled.stats.vertexTiles, tiled.stats.fieldTiles);
  expectSameBytes(tiled.mesh, generated.mesh, "the tiles' kernels, built after a generated job");
}

// The tiles' kernels build unbidden after a job only where their build is predicted quick
// (GpuPolygonizeOptions::unbiddenBuildSeconds); a longer one waits for expected runs that repay
// it. Here every build counts as long: three runs of a tower whose vertex pass takes milliseconds
// cannot repay a build of a second, a billion can.
TEST_F(BackgroundBuildTest, ALongTileBuildStartsOnlyWhereTheExpectedRunsRepayIt) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 48);
  const vk::CodegenOptions codegen = unrolledCodegen(device());
  // Whether the job after a first one, once the background builds are done, finds the tiles'
  // vertex kernels built.
  auto nextJobRunsTiles = [&](std::uint32_t expectedRuns, double unbiddenSeconds) {
    vk::Device fresh(device().host());
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Specialised;
    o.codegen = &codegen;
    o.expectedRuns = expectedRuns;
    o.unbiddenBuildSeconds = unbiddenSeconds;
    vk::GpuStats first, next;
    const mesh::TriMesh a = vk::polygonize(fresh, program, grid, o, &first);
    EXPECT_TRUE(first.vertexGradient);
    EXPECT_GT(first.fieldTiles, 1u);
    EXPECT_EQ(first.vertexTiles, 0u);  // the whole program's kernel: the tiles' are not built yet
    fresh.waitForBackgroundBuilds();
    const mesh::TriMesh b = vk::polygonize(fresh, program, grid, o, &next);
    expectSameBytes(b, a, "the job after the first");
    EXPECT_TRUE(next.vertexTiles == 0 || next.vertexTiles == next.fieldTiles);
    return next.vertexTiles > 0;
  };
  EXPECT_TRUE(nextJobRunsTiles(3, 10.0));          // quick: built for the two runs after
  EXPECT_FALSE(nextJobRunsTiles(3, 0.0));          // long, and two runs cannot repay it
  EXPECT_TRUE(nextJobRunsTiles(1000000000u, 0.0));  // long, repaid
}

TEST_F(BackgroundBuildTest, OneExpectedRunBuildsNothingInTheBackground) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 32);
  vk::Device fresh(device().host());
  const Job only = polygonizeOn(fresh, program, grid, true, 1);
  EXPECT_FALSE(only.stats.vertexGradient);
  EXPECT_EQ(fresh.backgroundBuildsStarted(), 0u);
  EXPECT_FALSE(only.mesh.triangles.empty());
}

// The model's decision follows its own estimates: one interpreted vertex pass against the
// generated kernel's build and run. Tower's unrolled vertex kernel (268 instructions, the field,
// gradient and colour spelled out) is predicted to build for longer than an interpreted pass at
// 256 cells; dice's (48) builds in a fraction of its interpreted pass; a built kernel is never
// waited for.
TEST(BackgroundBuildModel, InterpretsFirstOnlyWhereTheBuildCostsMore) {
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.repeats = 3;
  const vk::CodegenOptions codegen = vk::defaultCodegenOptions(true);
  const ShippedScene tower = shipped("tower", 256);
  const vk::EvaluatorChoice towerChoice = vk::chooseEvaluator(true, tower.program, tower.grid, job, codegen);
  ASSERT_EQ(towerChoice.chosen.traversal, vk::Traversal::Specialised);
  EXPECT_TRUE(towerChoice.chosen.vertexGradient);
  EXPECT_TRUE(towerChoice.chosen.interpretVertexPassUntilBuilt);

  const vk::KernelBuiltQuery vertexKernelBuilt = [](const std::string& shader, const vk::CodegenOptions* c) {
    return shader == "vertices" && c && c->gradient;
  };
  EXPECT_FALSE(vk::chooseEvaluator(true, tower.program, tower.grid, job, codegen, vertexKernelBuilt)
                   .chosen.interpretVertexPassUntilBuilt);

  const ShippedScene dice = shipped("dice", 256);
  const vk::EvaluatorChoice diceChoice = vk::chooseEvaluator(true, dice.program, dice.grid, job, codegen);
  ASSERT_EQ(diceChoice.chosen.traversal, vk::Traversal::Specialised);
  EXPECT_FALSE(diceChoice.chosen.interpretVertexPassUntilBuilt);
}

}  // namespace
}  // namespace blobvk::testing
