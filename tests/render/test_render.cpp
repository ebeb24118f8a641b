#include "../vk/vk_fixture.h"
#include "render_models.h"

#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/render/render_gpu_mesh.h"
#include "blobvk/vk/render/render_mesh.h"

#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include <cmath>

namespace blobvk::testing {
namespace {

constexpr std::uint8_t kBackground[3] = {0, 0, 0};

vk::RenderStyle blackBackground(std::uint32_t samples) {
  vk::RenderStyle style;
  style.background = {0.0f, 0.0f, 0.0f};
  style.samples = samples;
  return style;
}

blobtree::GridSpec fineGrid(const blobtree::Program& program, float cell) {
  blobtree::GridRequest request;
  request.cellSize = cell;
  return blobtree::chooseGrid(program, {}, request);
}

vk::Camera lookAt(glm::vec3 eye, glm::vec3 target, float fov = 45.0f) {
  vk::Camera c;
  c.eye = eye;
  c.target = target;
  c.fovYDeg = fov;
  c.nearPlane = 0.5f;
  c.farPlane = 20.0f;
  return c;
}

// A sphere of radius r seen from distance D fills a disc of angular radius asin(r / D).
double expectedSpherePixels(double r, double distance, double fovYDeg, std::uint32_t height) {
  const double rho = std::tan(std::asin(r / distance)) / std::tan(glm::radians(fovYDeg) / 2) * height / 2;
  return M_PI * rho * rho;
}

using RenderTest = VulkanTest;

TEST_F(RenderTest, UnitSphereCoversTheExpectedPixels) {
  const auto program = blobtree::compile(sphere({0, 0, 0}, 1.0));
  const auto mesh = cpu::polygonizeReference(program, fineGrid(program, 0.02f));
  ASSERT_GT(mesh.triangleCount(), 1000u);
  vk::MeshRenderer renderer(device(), 256, 256, blackBackground(1));
  const auto image = renderer.render(mesh, lookAt({0, 0, 4}, {0, 0, 0}));
  const double covered = double(vk::countCoveredPixels(image, kBackground));
  const double expected = expectedSpherePixels(1.0, 4.0, 45.0, 256);
  EXPECT_NEAR(covered / expected, 1.0, 0.01) << covered << " pixels, expected " << expected;
  // Row 0 is the top: the top-left corner is background, the centre is the lit sphere.
  EXPECT_EQ(image.pixel(0, 0)[0], 0);
  EXPECT_GT(image.pixel(128, 128)[0], 100);
}

TEST_F(RenderTest, MsaaIsUsedWhenTheDeviceHasIt) {
  vk::MeshRenderer renderer(device(), 64, 64, blackBackground(4));
  const auto& limits = device().info().limits;
  if (limits.framebufferColorSampleCounts & limits.framebufferDepthSampleCounts & VK_SAMPLE_COUNT_4_BIT) {
    EXPECT_EQ(renderer.samples(), 4u);
  } else {
    EXPECT_LE(renderer.samples(), 4u);
  }
  // Anti-aliased silhouettes: pixels the single-sample image leaves empty get partial colour.
  const auto program = blobtree::compile(sphere({0, 0, 0}, 1.0));
  const auto mesh = cpu::polygonizeReference(program, fineGrid(program, 0.05f));
  vk::MeshRenderer aliased(device(), 64, 64, blackBackground(1));
  const auto smooth = renderer.render(mesh, lookAt({0, 0, 4}, {0, 0, 0}));
  const auto hard = aliased.render(mesh, lookAt({0, 0, 4}, {0, 0, 0}));
  int partial = 0;
  for (std::uint32_t y = 0; y < 64; ++y) {
    for (std::uint32_t x = 0; x < 64; ++x) partial += hard.pixel(x, y)[0] == 0 && smooth.pixel(x, y)[0] > 2;
  }
  if (renderer.samples() > 1) {
    EXPECT_GE(partial, 8);
  }
}

// Red sphere in front of blue along the view axis: red wins; from the other side, blue wins.
TEST_F(RenderTest, DepthOrderIsRight) {
  const auto program = blobtree::compile(
      unionOf({sphere({0.3, 0, 1.2}, 0.8, {1, 0, 0}), sphere({-0.3, 0, -1.2}, 0.8, {0, 0, 1})}));
  const auto mesh = cpu::polygonizeReference(program, fineGrid(program, 0.05f));
  vk::MeshRenderer renderer(device(), 128, 128, blackBackground(4));
  const auto front = renderer.render(mesh, lookAt({0, 0, 6}, {0, 0, 0}));
  const auto back = renderer.render(mesh, lookAt({0, 0, -6}, {0, 0, 0}));
  const auto* p = front.pixel(64, 64);
  EXPECT_GT(p[0], p[2] + 50) << "front view: the red sphere must hide the blue one";
  const auto* q = back.pixel(64, 64);
  EXPECT_GT(q[2], q[0] + 50) << "back view: the blue sphere must hide the red one";
}

TEST_F(RenderTest, GpuMeshDrawnFromIndirectArgsMatchesTheCpuMesh) {
  const auto program = blobtree::compile(
      unionOf({sphere({0.3, 0, 0.5}, 0.8, {1, 0.5, 0}), sphere({-0.4, 0.2, -0.5}, 0.7, {0, 0.6, 1})}));
  const auto grid = fineGrid(program, 0.05f);
  const auto gpu = vk::polygonizeForDrawing(device(), program, grid);
  ASSERT_FALSE(gpu.fromReadback);
  ASSERT_NE(gpu.view().indirect, VkBuffer(VK_NULL_HANDLE));
  vk::MeshRenderer renderer(device(), 160, 128, blackBackground(4));
  const auto camera = lookAt({2, 1.5, 4}, {0, 0, 0});
  const auto fromGpu = renderer.render(gpu.view(), camera);
  const auto fromCpu = renderer.render(cpu::polygonizeReference(program, grid), camera);
  const auto diff = vk::compareImages(fromGpu, fromCpu, 8.0 / 255.0);
  EXPECT_LT(diff.fractionOver, 0.005) << "PSNR " << diff.psnr;
  EXPECT_GT(vk::countCoveredPixels(fromGpu, kBackground), 2000u);
}

TEST_F(RenderTest, WireframeDrawsDarkEdgesOverTheSurface) {
  const auto program = blobtree::compile(sphere({0, 0, 0}, 1.0, {0.9, 0.9, 0.9}));
  const auto mesh = cpu::polygonizeReference(program, fineGrid(program, 0.2f));
  auto style = blackBackground(1);
  vk::MeshRenderer plain(device(), 128, 128, style);
  style.wireframe = true;
  style.wireColour = {0.0f, 1.0f, 0.0f};
  vk::MeshRenderer wired(device(), 128, 128, style);
  const auto a = plain.render(mesh, lookAt({0, 0, 4}, {0, 0, 0}));
  const auto b = wired.render(mesh, lookAt({0, 0, 4}, {0, 0, 0}));
  int green = 0;
  for (std::uint32_t y = 0; y < 128; ++y) {
    for (std::uint32_t x = 0; x < 128; ++x) green += b.pixel(x, y)[1] == 255 && b.pixel(x, y)[0] == 0;
  }
  EXPECT_GT(green, 200);
  // Lines cover the same surface (silhouette edges may reach half a pixel beyond it).
  EXPECT_NEAR(double(vk::countCoveredPixels(b, kBackground)) / double(vk::countCoveredPixels(a, kBackground)),
              1.0, 0.05);
}

}  // namespace
}  // namespace blobvk::testing
