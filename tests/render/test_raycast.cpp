#include "../vk/vk_fixture.h"
#include "render_models.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/raycast_lipschitz.h"
#include "blobvk/vk/render/render_mesh.h"

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace blobvk::testing {
namespace {

constexpr std::uint8_t kBackground[3] = {0, 0, 0};

vk::Camera lookAt(glm::vec3 eye, glm::vec3 target) {
  vk::Camera c;
  c.eye = eye;
  c.target = target;
  c.nearPlane = 0.5f;
  c.farPlane = 20.0f;
  return c;
}

// The bound must hold for every pair of points: sample pairs (near and far apart) in the bounds.
void expectBoundHolds(const blobtree::Program& program, const std::string& what) {
  const auto bound = vk::lipschitzBound(program, program.bounds);
  ASSERT_GT(bound.lipschitz, 0.0f) << what;
  std::mt19937 rng(7);
  const glm::vec3 lo = program.bounds.lo, hi = program.bounds.hi;
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float diag = glm::length(hi - lo);
  float steepest = 0.0f;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 p = lo + (hi - lo) * glm::vec3(u(rng), u(rng), u(rng));
    const glm::vec3 dir = glm::normalize(glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f));
    const float h = diag * (i % 2 ? 1e-3f : 2e-2f);
    const float slope = std::abs(blobtree::evaluate(program, p + h * dir) - blobtree::evaluate(program, p)) / h;
    steepest = std::max(steepest, slope);
  }
  EXPECT_LE(steepest, bound.lipschitz * 1.001f) << what;
  EXPECT_GT(steepest, 0.0f) << what;
  // Tight enough to be useful on simple models.
  std::printf("[ lipschitz ] %s: bound %.3f, steepest sampled %.3f\n", what.c_str(), bound.lipschitz, steepest);
}

TEST(LipschitzBound, HoldsOnSampledSlopesOfTheShippedScenes) {
  expectBoundHolds(blobtree::compile(sphere({0, 0, 0}, 1.0)), "sphere");
  for (const char* name : {"tower", "twisted_column", "eggshell", "creature", "dice"}) {
    const std::string path = std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + name + ".json";
    const auto scene = blobtree::loadScene(path);
    const auto program = blobtree::compile(scene.root);
    if (!program.bounds.finite()) continue;
    expectBoundHolds(program, name);
  }
}

TEST(LipschitzBound, ASingleSphereIsBoundedByTheKernelSlope) {
  const double radius = 1.0;
  const auto program = blobtree::compile(sphere({0, 0, 0}, radius));
  const float support = float(supportForRadius(radius));
  EXPECT_NEAR(vk::lipschitzBound(program, program.bounds).lipschitz, float(96.0 / (25.0 * std::sqrt(5.0))) / support, 2e-3f);
}

using RaycastTest = VulkanTest;

TEST_F(RaycastTest, UnitSphereCoversTheExpectedPixels) {
  const auto program = blobtree::compile(sphere({0, 0, 0}, 1.0));
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  vk::Raycaster raycaster(device(), program, options);
  const auto image = raycaster.render(lookAt({0, 0, 4}, {0, 0, 0}), 256, 256);
  const double rho = std::tan(std::asin(0.25)) / std::tan(glm::radians(22.5)) * 128.0;
  const double expected = M_PI * rho * rho;
  const double covered = double(vk::countCoveredPixels(image, kBackground));
  EXPECT_NEAR(covered / expected, 1.0, 0.01) << covered << " vs " << expected;
}

TEST_F(RaycastTest, LookingAwayGivesOnlyBackground) {
  const auto program = blobtree::compile(sphere({0, 0, 0}, 1.0));
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  vk::Raycaster raycaster(device(), program, options);
  const auto image = raycaster.render(lookAt({0, 0, 4}, {0, 0, 8}), 64, 64);
  EXPECT_EQ(vk::countCoveredPixels(image, kBackground), 0u);
}

// The ray-cast and the raster image of a fine mesh agree except along silhouettes.
TEST_F(RaycastTest, MatchesTheRasterImageOfAFineMesh) {
  const auto program = blobtree::compile(
      unionOf({sphere({0.3, 0, 0.5}, 0.8, {1, 0.5, 0.1}), sphere({-0.4, 0.2, -0.5}, 0.7, {0.1, 0.6, 1})}));
  blobtree::GridRequest request;
  request.cellSize = 0.02f;
  const auto mesh = cpu::polygonizeReference(program, blobtree::chooseGrid(program, {}, request));
  const auto camera = lookAt({2, 1.5, 4}, {0, 0, 0});
  vk::RenderStyle style;
  style.background = {0, 0, 0};
  style.samples = 1;  // pixel-centre sampling, like the ray-caster
  vk::MeshRenderer renderer(device(), 192, 192, style);
  const auto raster = renderer.render(mesh, camera);
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  const auto cast = vk::Raycaster(device(), program, options).render(camera, 192, 192);
  const auto diff = vk::compareImages(raster, cast, 0.1);
  std::printf("[ raycast vs raster ] max %.3f, over 0.1: %.4f, mean %.4f, PSNR %.1f dB\n",
              diff.maxDifference, diff.fractionOver, diff.meanDifference, diff.psnr);
  EXPECT_LT(diff.fractionOver, 0.01);
  EXPECT_GT(diff.psnr, 30.0);
}

}  // namespace
}  // namespace blobvk::testing
