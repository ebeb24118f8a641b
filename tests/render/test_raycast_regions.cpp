// The ray-caster never drops a surface silently (vk/render/raycast.h): per-cell Lipschitz bounds keep a
// far, steep component from slowing every ray, and a ray that still runs out of its step budget
// is counted and its pixel marked. Oracles: analytic silhouettes, the raster image of the CPU
// reference mesh, and sampled slopes of the CPU reference field.
#include "../vk/vk_fixture.h"
#include "render_models.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/raycast_lipschitz.h"
#include "blobvk/vk/render/render_mesh.h"

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

namespace blobvk::testing {
namespace {

constexpr std::uint8_t kBlack[3] = {0, 0, 0};
// Iso radius of a point primitive of unit support: (1 - d^2)^3 = 1/2.
const double kIsoRadius = std::sqrt(1.0 - std::pow(0.5, 1.0 / 3.0));

blobtree::Node scaledPoint(glm::dvec3 at, glm::dvec3 scale, glm::dvec3 colour) {
  blobtree::Primitive p;
  p.type = blobtree::PrimitiveType::Point;
  p.colour = colour;
  blobtree::Node n{p, "", {}, {}};
  n.transform.translate = at;
  n.transform.scale = scale;
  return n;
}

blobtree::Node blend(std::vector<blobtree::Node> children) {
  blobtree::Operator o;
  o.type = blobtree::OperatorType::Blend;
  return blobtree::Node{o, "", {}, std::move(children)};
}

// The scene of issue 15: a disc 0.01 thick (L ~ 172 near it) far from a sphere of scale 3.
blobtree::Program issueScene() {
  return blobtree::compile(blend({scaledPoint({20, 3, 0}, {0.01, 3, 3}, {1, 0.5, 0.1}),
                                  scaledPoint({-20, -3, 0}, {3, 3, 3}, {0.1, 0.6, 1})}));
}

// Looking down -x: the disc face-on 40 away above the axis, the sphere 80 away below it.
vk::Camera issueCamera() {
  vk::Camera c;
  c.eye = {60, 0, 0};
  c.target = {0, 0, 0};
  c.fovYDeg = 15.0f;
  c.nearPlane = 1.0f;
  c.farPlane = 200.0f;
  return c;
}

std::uint64_t coveredRows(const vk::Image& image, std::uint32_t row0, std::uint32_t row1) {
  std::uint64_t n = 0;
  for (std::uint32_t y = row0; y < row1; ++y)
    for (std::uint32_t x = 0; x < image.width; ++x) {
      const std::uint8_t* p = &image.rgba[(std::size_t(y) * image.width + x) * 4];
      n += (p[0] | p[1] | p[2]) != 0;
    }
  return n;
}

std::uint64_t markedPixels(const vk::Image& image) {
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
    std::uint32_t v;
    std::memcpy(&v, &image.rgba[i], 4);
    n += v == vk::kRaycastBudgetMarker;
  }
  return n;
}

// Samples pairs of nearby points inside each cell of `grid` and checks the cell's bound against
// their reference field difference; returns how many pairs had a non-zero field.
std::size_t expectCellBoundsHold(const blobtree::Program& program, const vk::LipschitzGrid& grid, const char* what) {
  const glm::vec3 size = (grid.region.hi - grid.region.lo) /
                         glm::vec3(float(grid.dims[0]), float(grid.dims[1]), float(grid.dims[2]));
  auto cellOf = [&](glm::vec3 p) {
    const glm::ivec3 c = glm::clamp(glm::ivec3(glm::floor((p - grid.region.lo) / size)), glm::ivec3(0),
                                    glm::ivec3(int(grid.dims[0]), int(grid.dims[1]), int(grid.dims[2])) - 1);
    return (std::size_t(c.z) * grid.dims[1] + std::size_t(c.y)) * grid.dims[0] + std::size_t(c.x);
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::size_t checked = 0;
  for (int i = 0; i < 200000; ++i) {
    const glm::vec3 p = grid.region.lo + (grid.region.hi - grid.region.lo) * glm::vec3(u(rng), u(rng), u(rng));
    const std::size_t c = cellOf(p);
    const glm::vec3 q = p + size * 0.05f * glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f);
    if (cellOf(q) != c) continue;
    const float fp = blobtree::evaluate(program, p), fq = blobtree::evaluate(program, q);
    if (fp == 0.0f && fq == 0.0f) continue;
    ++checked;
    EXPECT_LE(std::abs(fp - fq), grid.cells[c] * glm::length(p - q) * 1.001f + 1e-6f) << what << " sample " << i;
    if (::testing::Test::HasFailure()) break;
  }
  return checked;
}

std::size_t cellIndex(const vk::LipschitzGrid& grid, glm::vec3 p) {
  const glm::vec3 size = (grid.region.hi - grid.region.lo) /
                         glm::vec3(float(grid.dims[0]), float(grid.dims[1]), float(grid.dims[2]));
  const glm::ivec3 c = glm::ivec3(glm::floor((p - grid.region.lo) / size));
  return (std::size_t(c.z) * grid.dims[1] + std::size_t(c.y)) * grid.dims[0] + std::size_t(c.x);
}

// Each cell's bound holds for pairs of points inside that cell (sampled against the reference),
// and a far, steep component does not raise the bound elsewhere.
TEST(LipschitzGrid, EachCellBoundHoldsAndFarCellsStayFlat) {
  const auto program = issueScene();
  const auto grid = vk::lipschitzGrid(program, program.bounds, 16);
  EXPECT_GT(grid.largest(), 150.0f);  // next to the disc: 1.717 / 0.01
  EXPECT_LT(grid.cells[cellIndex(grid, {-20, -3, 0})], 0.6f);  // the sphere's own slope 1.717 / 3
  EXPECT_EQ(grid.cells[cellIndex(grid, {0, 0, 0})], 0.0f);      // between them the field is 0
  EXPECT_GT(expectCellBoundsHold(program, grid, "issue scene"), 100u);
}

// Under warps (twist and taper in the twisted column; twist, bend, taper and shear with a matrix
// in the test models' csg_warps) the per-axis reach keeps each cell's bound sound.
TEST(LipschitzGrid, CellBoundsHoldUnderWarps) {
  const auto column = blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/twisted_column.json").root);
  const auto columnGrid = vk::lipschitzGrid(column, column.bounds, 24);
  EXPECT_GT(expectCellBoundsHold(column, columnGrid, "twisted_column"), 1000u);
  EXPECT_LT(columnGrid.largest(), 100.0f);  // the whole-box twist bound was 1963
  const auto creature = blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/creature.json").root);
  blobtree::Aabb box;
  box.lo = glm::vec3(-2.5f);
  box.hi = glm::vec3(2.5f);
  EXPECT_GT(expectCellBoundsHold(creature, vk::lipschitzGrid(creature, box, 24), "creature"), 1000u);
}

using RaycastRegionsTest = VulkanTest;

// The issue's scene: both the thin disc and the far sphere appear, with their analytic areas,
// and no ray runs out of budget.
TEST_F(RaycastRegionsTest, FarSphereBesideASteepThinDiscIsNotDropped) {
  const auto program = issueScene();
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  vk::Raycaster raycaster(device(), program, options);
  vk::RaycastStats stats;
  const std::uint32_t size = 256;
  const auto image = raycaster.render(issueCamera(), size, size, &stats);
  EXPECT_EQ(stats.exhaustedRays, 0u);
  EXPECT_EQ(markedPixels(image), 0u);
  // A circle of radius r facing the camera at distance D: radius f r / D pixels.
  const double focal = size / 2.0 / std::tan(glm::radians(15.0 / 2.0));
  const double r = 3.0 * kIsoRadius;
  const double disc = M_PI * std::pow(focal * r / 40.0, 2.0);
  const double sphere = M_PI * std::pow(focal * std::tan(std::asin(r / 80.0)), 2.0);
  const double up = double(coveredRows(image, 0, size / 2)), down = double(coveredRows(image, size / 2, size));
  std::printf("[ issue scene ] disc %.0f px (analytic %.0f), sphere %.0f px (analytic %.0f), L max %.1f\n", up, disc,
              down, sphere, stats.lipschitz);
  EXPECT_NEAR(up / disc, 1.0, 0.02);
  EXPECT_NEAR(down / sphere, 1.0, 0.02);
}

// One bound for the whole scene (the old caster): the far sphere's rays run out of steps. They
// are counted, and exactly those pixels carry the marker colour.
TEST_F(RaycastRegionsTest, RaysOutOfBudgetAreCountedAndMarked) {
  const auto program = issueScene();
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  options.lipschitzCells = 1;
  vk::Raycaster global(device(), program, options);
  vk::RaycastStats stats;
  const auto image = global.render(issueCamera(), 128, 128, &stats);
  EXPECT_GT(stats.exhaustedRays, 100u);
  EXPECT_EQ(markedPixels(image), stats.exhaustedRays);
  EXPECT_EQ(global.exhaustedRays(), stats.exhaustedRays);
  // A tiny budget on a plain sphere: every ray that enters the bounds and misses within 2 steps.
  vk::RaycastOptions tiny;
  tiny.background = {0, 0, 0};
  tiny.maxSteps = 2;
  vk::Raycaster sphereCaster(device(), blobtree::compile(sphere({0, 0, 0}, 1.0)), tiny);
  vk::Camera c;
  c.eye = {0, 0, 4};
  const auto small = sphereCaster.render(c, 64, 64, &stats);
  EXPECT_GT(stats.exhaustedRays, 0u);
  EXPECT_EQ(markedPixels(small), stats.exhaustedRays);
  // With the default budget the same view has none.
  vk::Raycaster normal(device(), blobtree::compile(sphere({0, 0, 0}, 1.0)), options);
  normal.render(c, 64, 64, &stats);
  EXPECT_EQ(stats.exhaustedRays, 0u);
}

// llvmpipe ends a pixel's loops after 65,535 iterations (vk/extract/loop_limit.h); a blend of
// 1,500 points loops about 1,500 times a sample, so a ray gets a few dozen steps. The oracle: a
// ray through a point's centre (field 1 there) hits something, so the pixel holding a centre's
// projection is surface or marked, never the background; every marked ray is counted. Before the
// kernel counted its loops, such rays showed the background and the image was nearly empty.
TEST_F(RaycastRegionsTest, RaysTheDriverWouldCutShortAreMarkedNotDropped) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> at(-10.0, 10.0);
  std::vector<blobtree::Node> points;
  std::vector<glm::vec3> centres;
  for (int i = 0; i < 1500; ++i) {
    const glm::dvec3 c(at(rng), at(rng), at(rng));
    points.push_back(scaledPoint(c, glm::dvec3(1.0), glm::dvec3(0.8)));
    centres.push_back(glm::vec3(c));
  }
  const blobtree::Program program = blobtree::compile(blend(std::move(points)));
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  vk::Raycaster caster(device(), program, options);
  vk::Camera camera;
  camera.eye = {0, 0, 40};
  camera.target = {0, 0, 0};
  camera.fovYDeg = 40.0f;
  const std::uint32_t size = 96;
  vk::RaycastStats stats;
  const vk::Image image = caster.render(camera, size, size, &stats);
  EXPECT_EQ(markedPixels(image), stats.exhaustedRays);
  const glm::vec3 forward = glm::normalize(camera.target - camera.eye);
  const glm::vec3 right = glm::normalize(glm::cross(forward, camera.up)), up = glm::cross(right, forward);
  const float tanY = std::tan(glm::radians(camera.fovYDeg) * 0.5f);
  std::size_t checked = 0, background = 0;
  for (const glm::vec3& c : centres) {
    const glm::vec3 v = c - camera.eye;
    const float z = glm::dot(v, forward);
    const float x = glm::dot(v, right) / (z * tanY), y = glm::dot(v, up) / (z * tanY);
    const float px = (x + 1.0f) * 0.5f * float(size), py = (1.0f - y) * 0.5f * float(size);
    if (px < 0.0f || py < 0.0f || px >= float(size) || py >= float(size)) continue;
    const std::uint8_t* p = &image.rgba[(std::size_t(py) * size + std::size_t(px)) * 4];
    ++checked;
    background += (p[0] | p[1] | p[2]) == 0;
  }
  ASSERT_GT(checked, 1000u);
  EXPECT_EQ(background, 0u) << "of " << checked << " pixels over a point's centre";
  if (vk::loopIterationLimit(device().info()) != ~0ull) {
    EXPECT_GT(stats.exhaustedRays, 0u);
  }
}

mesh::TriMesh append(mesh::TriMesh a, const mesh::TriMesh& b) {
  const auto base = std::uint32_t(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  a.normals.insert(a.normals.end(), b.normals.begin(), b.normals.end());
  a.colours.insert(a.colours.end(), b.colours.begin(), b.colours.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  return a;
}

// Thin and far features against the raster image of the CPU reference mesh: a plate 0.1 thick
// seen face-on, a small sphere far behind it and a thin rod. The components are far enough apart
// not to blend, so each is polygonized on a grid fine enough for it alone.
TEST_F(RaycastRegionsTest, ThinAndFarFeaturesMatchTheRasterImage) {
  const auto plate = scaledPoint({0, 0, 0}, {0.1, 1.2, 1.2}, {1, 0.6, 0.2});
  const auto rod = scaledPoint({0, 1.6, 0}, {0.08, 0.4, 0.08}, {0.3, 1, 0.3});
  const auto far = scaledPoint({14, -0.5, 0.5}, {0.8, 0.8, 0.8}, {0.2, 0.5, 1});
  const auto program = blobtree::compile(blend({plate, rod, far}));
  auto meshOf = [&](const blobtree::Node& n, float cell) {
    const auto p = blobtree::compile(n);
    blobtree::GridRequest request;
    request.cellSize = cell;
    return cpu::polygonizeReference(p, blobtree::chooseGrid(p, {}, request));
  };
  const auto mesh = append(append(meshOf(plate, 0.01f), meshOf(rod, 0.008f)), meshOf(far, 0.02f));
  vk::Camera camera;
  camera.eye = {-5, 0.8, 2.5};
  camera.target = {3, 0.3, 0.5};
  camera.fovYDeg = 40.0f;
  camera.nearPlane = 0.5f;
  camera.farPlane = 40.0f;
  vk::RenderStyle style;
  style.background = {0, 0, 0};
  style.samples = 1;
  const auto raster = vk::MeshRenderer(device(), 192, 192, style).render(mesh, camera);
  vk::RaycastOptions options;
  options.background = {0, 0, 0};
  vk::RaycastStats stats;
  const auto cast = vk::Raycaster(device(), program, options).render(camera, 192, 192, &stats);
  EXPECT_EQ(stats.exhaustedRays, 0u);
  const auto diff = vk::compareImages(raster, cast, 0.1);
  const double rasterCover = double(vk::countCoveredPixels(raster, kBlack));
  const double castCover = double(vk::countCoveredPixels(cast, kBlack));
  std::printf("[ thin and far ] covered raster %.0f, raycast %.0f; over 0.1: %.4f, PSNR %.1f dB\n", rasterCover,
              castCover, diff.fractionOver, diff.psnr);
  EXPECT_NEAR(castCover / rasterCover, 1.0, 0.03);
  EXPECT_LT(diff.fractionOver, 0.02);
  // Each feature shows: the far sphere's, the rod's and the plate's pixels (projected centres).
  auto litAt = [&](const vk::Image& im, glm::vec3 world) {
    const glm::vec3 f = glm::normalize(camera.target - camera.eye);
    const glm::vec3 r = glm::normalize(glm::cross(f, camera.up)), u = glm::cross(r, f);
    const glm::vec3 d = world - camera.eye;
    const float t = std::tan(glm::radians(camera.fovYDeg) * 0.5f);
    const float x = glm::dot(d, r) / glm::dot(d, f) / t, y = glm::dot(d, u) / glm::dot(d, f) / t;
    const auto px = std::uint32_t((x * 0.5f + 0.5f) * float(im.width)), py = std::uint32_t((0.5f - y * 0.5f) * float(im.height));
    const std::uint8_t* p = &im.rgba[(std::size_t(py) * im.width + px) * 4];
    return (p[0] | p[1] | p[2]) != 0;
  };
  for (glm::vec3 centre : {glm::vec3(14, -0.5, 0.5), glm::vec3(0, 1.6, 0), glm::vec3(0, -0.3, 0.3)}) {
    EXPECT_TRUE(litAt(raster, centre)) << centre.x << " " << centre.y;
    EXPECT_TRUE(litAt(cast, centre)) << centre.x << " " << centre.y;
  }
}

}  // namespace
}  // namespace blobvk::testing
