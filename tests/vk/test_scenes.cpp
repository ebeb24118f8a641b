// Every shipped scene (scenes/*.json): the GPU field of both traversals against the scalar CPU
// reference. The shipped scenes mix box skips that some lanes of a subgroup take and others do
// not, which is what the stackless evaluator's masked skips (eval_body.glsl) must get right.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/polygonize.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

class SceneFieldTest : public VulkanTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(SceneFieldTest, EveryTraversalMatchesScalarReference) {
  const auto scene =
      blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + GetParam() + ".json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = 28;
  const auto grid = blobtree::chooseGrid(program, scene.grid, request);
  const auto pts = grid.points();
  std::vector<float> cpu(grid.pointCount());
  for (int k = 0; k < pts.z; ++k)
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i)
        cpu[grid.pointIndex(i, j, k)] = blobtree::evaluate(program, grid.point(i, j, k));
  for (auto traversal : {vk::Traversal::Stackless, vk::Traversal::StackBased, vk::Traversal::Specialised}) {
    vk::FieldOptions o;
    o.traversal = traversal;
    const auto gpu = vk::evaluateFieldOnGrid(device(), program, grid, o);
    ASSERT_EQ(gpu.size(), cpu.size());
    float worst = 0.0f;
    std::size_t nonZero = 0;
    for (std::size_t n = 0; n < cpu.size(); ++n) {
      worst = std::max(worst, std::abs(gpu[n] - cpu[n]));
      nonZero += cpu[n] != 0.0f;
    }
    EXPECT_LT(worst, 1e-5f) << GetParam() << " " << vk::traversalName(traversal);
    EXPECT_GT(nonZero, 0u) << "the grid misses the model";
  }
}

// The GPU mesh against the CPU reference mesh, index by index: same edge keys (vertex order),
// same triangles, positions within 1e-4 of a cell, on every shipped scene.
TEST_P(SceneFieldTest, GpuMeshEqualsReferenceMesh) {
  const auto scene =
      blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + GetParam() + ".json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = 24;
  const auto grid = blobtree::chooseGrid(program, scene.grid, request);
  const mesh::TriMesh cpu = cpu::polygonizeReference(program, grid);
  ASSERT_GT(cpu.triangleCount(), 0u) << GetParam();
  for (auto traversal : {vk::Traversal::Stackless, vk::Traversal::Specialised}) {
    vk::GpuPolygonizeOptions options;
    options.traversal = traversal;
    const mesh::TriMesh gpu = vk::polygonize(device(), program, grid, options);
    const std::string what = GetParam() + " " + vk::traversalName(traversal);
    EXPECT_EQ(gpu.edgeKeys, cpu.edgeKeys) << what;
    EXPECT_EQ(gpu.triangles, cpu.triangles) << what;
    ASSERT_EQ(gpu.positions.size(), cpu.positions.size()) << what;
    float worst = 0.0f;
    for (std::size_t i = 0; i < cpu.positions.size(); ++i) {
      worst = std::max({worst, std::abs(gpu.positions[i].x - cpu.positions[i].x),
                        std::abs(gpu.positions[i].y - cpu.positions[i].y),
                        std::abs(gpu.positions[i].z - cpu.positions[i].z)});
    }
    EXPECT_LE(worst, 1e-4f * grid.cellSize) << what;
  }
}

// The interpreter and the specialised code give the same mesh byte for byte (positions, normals,
// colours, triangles, keys), with refinement steps too: the precondition for running the
// interpreter while a specialised kernel builds and switching between slabs (issue 20).
TEST_P(SceneFieldTest, InterpreterAndSpecialisedMeshesAreByteIdentical) {
  const auto scene =
      blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + GetParam() + ".json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = 24;
  const auto grid = blobtree::chooseGrid(program, scene.grid, request);
  for (int refineSteps : {0, 2}) {
    vk::GpuPolygonizeOptions options;
    options.refineSteps = refineSteps;
    options.traversal = vk::Traversal::Stackless;
    const mesh::TriMesh interpreted = vk::polygonize(device(), program, grid, options);
    options.traversal = vk::Traversal::Specialised;
    const mesh::TriMesh specialised = vk::polygonize(device(), program, grid, options);
    ASSERT_GT(interpreted.triangleCount(), 0u) << GetParam();
    ASSERT_FALSE(interpreted.normals.empty());
    const std::string what = GetParam() + ", " + std::to_string(refineSteps) + " refinement steps";
    // Bit for bit on lavapipe; on other drivers sin/cos/pow may round differently in the two
    // code shapes (docs/vulkan.md), so the vertices agree to a hundredth of a cell.
    const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const float cell = grid.cellSize;
    expectSameMeshWithin(interpreted, specialised, lavapipe ? 0.0f : 1e-2f * cell, lavapipe ? 0.0f : 1e-2f,
                         lavapipe ? 0.0f : 1e-3f, what);
  }
}

INSTANTIATE_TEST_SUITE_P(Shipped, SceneFieldTest, ::testing::ValuesIn(shippedSceneNames()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace blobvk::testing
