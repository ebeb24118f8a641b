// Row culling (vk/extract/row_culling.h): the field pass on llvmpipe skips the rows of points that
// the CPU backend's bound (cpu::ColumnSides, tested against the field in
// tests/cpu_simd/test_column_sides.cpp) proves on one side of the iso-value. With culling, the mesh
// of every shipped scene it applies to is the CPU reference's and the bytes of the run without it,
// in one batch and in batches of a few bricks, with bricks of 16 and 8, on the specialised tiles
// and the interpreter; fewer points are evaluated.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/column_sides.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "models.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

vk::GpuPolygonizeOptions culling(const std::shared_ptr<cpu::ColumnSides>& sides) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides](const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                         std::uint8_t* out) { (*sides)(x, nx, y, z, n, out); };
  return o;
}

// The same bound over whole columns only: each segment takes its column's side, so a row is
// evaluated whole or not at all.
vk::GpuPolygonizeOptions cullingWholeColumns(const std::shared_ptr<cpu::ColumnSides>& sides) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides](const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                         std::uint8_t* out) {
    const float ends[2] = {x[0], x[nx]};
    std::vector<std::uint8_t> columns(std::size_t(n) * n);
    (*sides)(ends, 1, y, z, n, columns.data());
    for (std::size_t c = 0; c < columns.size(); ++c)
      for (std::uint32_t i = 0; i < nx; ++i) out[i + nx * c] = columns[c];
  };
  return o;
}

TEST_F(VulkanTest, RowCullingGivesTheMeshOfEveryRow) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  std::uint64_t segmentSamples = 0, columnSamples = 0;
  for (const std::string& name : shippedSceneNames()) {
    ShippedScene s = shipped(name, 64);
    if (!cpu::ColumnSides::boundsHoldOnIeeeDevices(s.program)) continue;
    const auto sides = std::make_shared<cpu::ColumnSides>(s.program);
    const mesh::TriMesh reference = cpu::polygonizeReference(s.program, s.grid, {});
    struct Setting {
      std::uint32_t brickCells;
      vk::Traversal traversal;
      std::uint32_t batchBricks;
    };
    for (const Setting& setting : {Setting{16, vk::Traversal::Auto, 0}, Setting{16, vk::Traversal::Stackless, 7},
                                   Setting{8, vk::Traversal::Auto, 7}, Setting{8, vk::Traversal::Stackless, 0}}) {
          const auto [brickCells, traversal, batchBricks] = setting;
          const std::string what = name + ", bricks of " + std::to_string(brickCells) + ", " +
                                   vk::traversalName(traversal) + ", batches of " + std::to_string(batchBricks);
          vk::GpuPolygonizeOptions o = culling(sides);
          o.brickCells = brickCells;
          o.traversal = traversal;
          o.maxBatchBricks = batchBricks;
          vk::GpuStats culled, whole, every;
          const mesh::TriMesh m = vk::polygonize(device(), s.program, s.grid, o, &culled);
          o.columnSides = cullingWholeColumns(sides).columnSides;
          const mesh::TriMesh byColumns = vk::polygonize(device(), s.program, s.grid, o, &whole);
          o.columnSides = nullptr;
          const mesh::TriMesh all = vk::polygonize(device(), s.program, s.grid, o, &every);
          expectSameBytes(m, all, what);
          expectSameBytes(byColumns, all, what + ", whole columns");
          expectSameMeshAsReference(m, reference, 1e-4f * s.grid.cellSize, what);
          // The row lists are in the device memory that --max-memory estimates.
          EXPECT_LE(culled.deviceBytes, vk::sparseDeviceBytes(vk::brickGridFor(s.grid, culled.brickCells), culled.activeBricks,
                                                              m.positions.size(), m.triangles.size(), true, true,
                                                              culled.tapeBytes))
              << what;
          // Every row of an active brick without culling; with whole columns, whole rows and fewer
          // of them; with segments, at most as many points again.
          const std::uint64_t R = every.brickCells + 1;  // tower_L6P8I4 takes 8 on llvmpipe (its loop limit)
          EXPECT_EQ(culled.brickCells, every.brickCells) << what;
          if (every.batches == 1) {
            EXPECT_EQ(every.fieldEvaluations, std::uint64_t(every.activeBricks) * R * R * R) << what;
          }
          EXPECT_EQ(whole.fieldEvaluations % R, 0u) << what;
          EXPECT_LE(culled.fieldEvaluations, whole.fieldEvaluations) << what;
          if (!reference.triangles.empty()) {
            EXPECT_LT(whole.fieldEvaluations, every.fieldEvaluations) << what;
          }
          segmentSamples += culled.fieldEvaluations;
          columnSamples += whole.fieldEvaluations;
        }
  }
  // Segments of four cells along x cull points of rows that whole columns evaluate.
  EXPECT_LT(double(segmentSamples), 0.9 * double(columnSamples));
}

// A program on a grid, for the tests of programs whose device values are not the CPU's bit for bit.
struct DeviceModel {
  std::string name;
  blobtree::Program program;
  blobtree::GridSpec grid;
};

// Programs with Ricci blends (pow, whose llvmpipe results differ from the C library's in the last
// bits): the legacy tower fragment and blends of random points under Ricci powers from 0.5 to 8.
std::vector<DeviceModel> ricciModels(int resolution) {
  std::vector<DeviceModel> models;
  {
    const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/tower_fragment.blob");
    blobtree::GridRequest request;
    request.resolution = resolution;
    DeviceModel m{"tower_fragment.blob", blobtree::compile(scene.root), {}};
    m.grid = blobtree::chooseGrid(m.program, scene.grid, request);
    models.push_back(std::move(m));
  }
  for (const double power : {0.5, 2.0, 8.0}) {  // (higher powers: ColumnSides claims no bound)
    DeviceModel m{"24 points, Ricci " + std::to_string(power),
                 blobtree::compile(blobtree::generateRandomRicciBlobs(24, 7, power)), {}};
    m.grid = gridAt(m.program, resolution);
    models.push_back(std::move(m));
  }
  return models;
}

// How llvmpipe's field of `m` (by `traversal`) differs from blobtree::evaluate at every grid point:
// the largest difference relative to the value past 1 (as the bounds' own rounding margin is),
// how many points differ, and how many lie within 0.1 of the iso-value.
struct FieldDifference {
  double worst = 0.0;
  std::size_t differ = 0, near = 0;
};
FieldDifference fieldDifference(vk::Device& device, const DeviceModel& m, vk::Traversal traversal) {
  vk::FieldOptions o;
  o.traversal = traversal;
  const std::vector<float> gpu = vk::evaluateFieldOnGrid(device, m.program, m.grid, o);
  EXPECT_EQ(gpu.size(), m.grid.pointCount()) << m.name;
  FieldDifference d;
  if (gpu.size() != m.grid.pointCount()) return d;
  const auto points = m.grid.points();
  for (int k = 0; k < points.z; ++k)
    for (int j = 0; j < points.y; ++j)
      for (int i = 0; i < points.x; ++i) {
        const float cpu = blobtree::evaluate(m.program, m.grid.point(i, j, k));
        const float dev = gpu[m.grid.pointIndex(i, j, k)];
        d.worst = std::max(d.worst, double(std::abs(dev - cpu)) / std::max(1.0, double(std::abs(cpu))));
        d.differ += dev != cpu;
        d.near += std::abs(cpu - layout::ISO_VALUE) < 0.1f;
      }
  return d;
}

// The culled rows of `m` give the bytes of every row, in one batch and in batches of 7 bricks, with
// the host's classification and at most as many bricks, on half the evaluations or fewer; and,
// given, the reference's mesh.
void expectCullingGivesEveryRow(vk::Device& device, const DeviceModel& m, const mesh::TriMesh* reference) {
  const auto sides = std::make_shared<cpu::ColumnSides>(m.program);
  for (const std::uint32_t batchBricks : {0u, 7u}) {
    const std::string what = m.name + ", batches of " + std::to_string(batchBricks);
    vk::GpuPolygonizeOptions o = culling(sides);
    o.maxBatchBricks = batchBricks;
    vk::GpuStats culled, every;
    const mesh::TriMesh m1 = vk::polygonize(device, m.program, m.grid, o, &culled);
    o.columnSides = nullptr;
    const mesh::TriMesh all = vk::polygonize(device, m.program, m.grid, o, &every);
    ASSERT_GT(all.triangleCount(), 0u) << what;
    expectSameBytes(m1, all, what);
    if (reference) expectSameMeshAsReference(m1, *reference, 1e-4f * m.grid.cellSize, what);
    EXPECT_TRUE(culled.hostClassification) << what;
    EXPECT_LE(culled.activeBricks, every.activeBricks) << what;
    EXPECT_LT(culled.fieldEvaluations, every.fieldEvaluations / 2) << what;
  }
}

// The bound keeps ColumnSides::kPowDeviceMargin from the iso-value for programs with a pow: the
// margin holds llvmpipe's fields of such programs a hundred times over (relative to the value
// where it is past 1: the Ricci blend of power 0.5 reaches 4.2, and differs by 1.4e-6 there).
TEST_F(VulkanTest, LlvmpipeRicciFieldsLieWellWithinTheRowCullingMargin) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  for (const DeviceModel& m : ricciModels(40)) {
    ASSERT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(m.program)) << m.name;
    for (const vk::Traversal traversal : {vk::Traversal::Specialised, vk::Traversal::Stackless}) {
      const auto [worst, differ, near] = fieldDifference(device(), m, traversal);
      EXPECT_LT(worst, cpu::ColumnSides::kPowDeviceMargin / 100.0) << m.name << ", " << vk::traversalName(traversal);
      EXPECT_GT(near, 100u) << m.name << ": the grid misses the surface";
      // The pow's last bits do differ (else this test would check nothing the other one doesn't).
      if (m.name == "tower_fragment.blob") {
        EXPECT_GT(differ, 0u) << m.name;
      }
    }
  }
}

// With that margin the culled rows of Ricci blends give the bytes of every row, and the host's
// classification drops the bricks the bound proves.
TEST_F(VulkanTest, RowCullingOfRicciBlendsGivesTheMeshOfEveryRow) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  for (const DeviceModel& m : ricciModels(64)) expectCullingGivesEveryRow(device(), m, nullptr);
}

// A bound belongs to one program, and an edit session's programs change: the extractor ignores
// the option. Given a bound that proves every column below the iso-value (wrong for this
// program), it still meshes every row.
TEST_F(VulkanTest, IncrementalExtractionIgnoresARowCullingBound) {
  const ShippedScene s = shipped("tower", 48);
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  const mesh::TriMesh whole = vk::polygonize(device(), s.program, s.grid, o);
  ASSERT_GT(whole.triangleCount(), 0u);
  o.columnSides = [](const float*, std::uint32_t nx, const float*, const float*, std::uint32_t n, std::uint8_t* sides) {
    for (std::uint32_t c = 0; c < nx * n * n; ++c) sides[c] = 0;
  };
  vk::IncrementalExtractor inc(device(), s.grid, o);
  expectSameBytes(inc.reset(s.program), whole, "incremental extractor with a wrong bound");
}

// Twisted and bent programs: their bounds turn a box by the warp's angles with a margin of a
// thousandth of the radius for a device's sin and cos (cpu_simd/field_bounds.cpp), llvmpipe's
// being far within it. Shipped twisted_column (in a Ricci blend, with tapers) and creature (a bend
// over a union of 19 primitives), a twisted intersection, blends twisted from half a radian a
// unit to twenty, off the axis, and a blend bent over part of its length and over all of it.
std::vector<DeviceModel> turnedModels(int resolution) {
  std::vector<DeviceModel> models;
  {
    ShippedScene s = shipped("creature", resolution);
    models.push_back({"creature", s.program, s.grid});
  }
  for (const bool region : {true, false}) {
    std::vector<blobtree::Node> points;
    for (int i = 0; i < 8; ++i) points.push_back(pointAt({-1.4 + 0.4 * i, 0.1 * (i % 3), 0.0}));
    blobtree::Warp w;
    w.type = blobtree::WarpType::Bend;
    w.axis = 0, w.otherAxis = 1, w.factor = 0.6, w.centre = -0.5;
    if (region) w.lo = -1.0, w.hi = 0.8;
    const blobtree::Program p =
        blobtree::compile(blobtree::Node{w, "", {}, {combine(blobtree::OperatorType::Blend, points)}});
    blobtree::GridSettings bounds;  // a bend is unbounded to compile(): the box it bends within
    bounds.boundsLo = glm::dvec3(-3.0, -3.0, -1.5);
    bounds.boundsHi = glm::dvec3(3.0, 3.0, 1.5);
    blobtree::GridRequest request;
    request.resolution = resolution;
    models.push_back({region ? "blend bent over part of its length" : "blend bent over all of it", p,
                      blobtree::chooseGrid(p, bounds, request)});
  }
  {
    ShippedScene s = shipped("twisted_column", resolution);
    models.push_back({"twisted_column", s.program, s.grid});
  }
  {
    std::vector<blobtree::Node> points;
    for (int y = -3; y <= 3; ++y) {
      auto p = pointAt({0.0, double(y), 0.0});
      std::get<blobtree::Primitive>(p.kind).support = 1.5;
      points.push_back(p);
    }
    auto cube = prim(blobtree::PrimitiveType::Cube, {0, 0, 0}, {1, 3, 1});
    std::get<blobtree::Primitive>(cube.kind).support = 0.5;
    const blobtree::Program p = blobtree::compile(warped(
        blobtree::WarpType::Twist, 1, 0, 0.5,
        combine(blobtree::OperatorType::Intersection, {cube, combine(blobtree::OperatorType::Blend, points)})));
    models.push_back({"twisted intersection", p, gridAt(p, resolution)});
  }
  for (const double k : {0.5, 3.0, 20.0}) {
    std::vector<blobtree::Node> points;
    for (int i = 0; i < 6; ++i) points.push_back(pointAt({3.0 + 0.5 * i, -1.0 + 0.4 * i, 0.3 * i}));
    const blobtree::Program p =
        blobtree::compile(warped(blobtree::WarpType::Twist, 1, 0, k, combine(blobtree::OperatorType::Blend, points)));
    models.push_back({"blend twisted by " + std::to_string(k), p, gridAt(p, resolution)});
  }
  return models;
}

// llvmpipe's twisted and bent fields differ from the CPU's by what its sin and cos move the points,
// about 1e-7 of the radius: under 1e-5 of the value (past 1), where the bounds' margin would allow
// differences of the order of 1e-3 of the radius times the field's slope.
TEST_F(VulkanTest, LlvmpipeTurnedFieldsDifferFromTheCpuByLastBitsOfSinAndCos) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  for (const DeviceModel& m : turnedModels(64)) {
    ASSERT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(m.program)) << m.name;
    const FieldDifference d = fieldDifference(device(), m, vk::Traversal::Specialised);
    EXPECT_LT(d.worst, 1e-5) << m.name;
    EXPECT_GT(d.differ, 0u) << m.name << ": sin and cos agree everywhere, so this checks nothing";
  }
}

// With those bounds the culled rows of twisted and bent programs give the bytes of every row, the
// host's classification drops the bricks the bounds prove, and the mesh is the CPU reference's.
TEST_F(VulkanTest, RowCullingOfTwistedAndBentProgramsGivesTheMeshOfEveryRow) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  for (const DeviceModel& m : turnedModels(64)) {
    const mesh::TriMesh reference = cpu::polygonizeReference(m.program, m.grid, {});
    expectCullingGivesEveryRow(device(), m, &reference);
  }
}


// The device's classification (every device but llvmpipe with the CPU's bound, and the library's
// default without one) turns twisted and bent boxes too, with its own margins for sin and cos
// (shaders/brick_classify_body.glsl): it keeps about the bricks the host's bound keeps, where the
// disc of a twist and a bend's whole space kept several times more, and the meshes stay the
// bytes of every row evaluated and the reference's.
TEST_F(VulkanTest, DeviceClassificationTurnsTwistedAndBentBoxes) {
  for (const DeviceModel& m : turnedModels(192)) {
    const auto sides = std::make_shared<cpu::ColumnSides>(m.program);
    vk::GpuPolygonizeOptions o = culling(sides);
    vk::GpuStats host, onDevice;
    const mesh::TriMesh byHost = vk::polygonize(device(), m.program, m.grid, o, &host);
    o.columnSides = nullptr;
    const mesh::TriMesh byDevice = vk::polygonize(device(), m.program, m.grid, o, &onDevice);
    expectSameBytes(byHost, byDevice, m.name);
    if (!device().info().isLlvmpipe()) continue;  // the host classifies on llvmpipe only
    EXPECT_TRUE(host.hostClassification) << m.name;
    EXPECT_FALSE(onDevice.hostClassification) << m.name;
    EXPECT_LE(onDevice.activeBricks, host.activeBricks * 3 / 2 + 8) << m.name;
  }
}

}  // namespace
}  // namespace blobvk::testing
