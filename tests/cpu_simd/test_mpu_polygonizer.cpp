// The MPU polygonizer against the reference polygonizer: the same mesh (topology exactly,
// positions within 1e-5 of a cell), the same bytes for 1, 2 and 3 threads, and no surface lost
// to the early discard on models built to fool it.
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "tests/cpu_simd/models.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::cpu {
namespace {

blobtree::GridSpec gridAround(const blobtree::Program& program, float cellSize,
                              glm::vec3 originShift = glm::vec3(0.0f)) {
  blobtree::GridSpec g;
  g.cellSize = cellSize;
  // Unbounded models (a bend at the root) get a fixed box that holds the test models.
  const bool finite = program.bounds.finite();
  const glm::vec3 lo = finite ? program.bounds.lo : glm::vec3(-2.5f);
  const glm::vec3 hi = finite ? program.bounds.hi : glm::vec3(2.5f);
  g.origin = lo - cellSize + originShift;
  const glm::vec3 extent = hi + cellSize - g.origin;
  g.cells = glm::ivec3(glm::ceil(extent / cellSize));
  return g;
}

void expectSameMesh(const mesh::TriMesh& mpu, const mesh::TriMesh& ref, float cellSize) {
  ASSERT_EQ(mpu.vertexCount(), ref.vertexCount());
  ASSERT_EQ(mpu.triangleCount(), ref.triangleCount());
  ASSERT_EQ(mpu.edgeKeys, ref.edgeKeys);
  ASSERT_EQ(mpu.triangles, ref.triangles);
  ASSERT_EQ(mpu.normals.size(), ref.normals.size());
  ASSERT_EQ(mpu.colours.size(), ref.colours.size());
  const float tol = 1e-5f * cellSize;
  for (std::size_t i = 0; i < ref.vertexCount(); ++i) {
    ASSERT_NEAR(mpu.positions[i].x, ref.positions[i].x, tol) << "vertex " << i;
    ASSERT_NEAR(mpu.positions[i].y, ref.positions[i].y, tol) << "vertex " << i;
    ASSERT_NEAR(mpu.positions[i].z, ref.positions[i].z, tol) << "vertex " << i;
  }
  for (std::size_t i = 0; i < ref.normals.size(); ++i) {
    ASSERT_NEAR(mpu.normals[i].x, ref.normals[i].x, 1e-5f);
    ASSERT_NEAR(mpu.normals[i].y, ref.normals[i].y, 1e-5f);
    ASSERT_NEAR(mpu.normals[i].z, ref.normals[i].z, 1e-5f);
  }
  for (std::size_t i = 0; i < ref.colours.size(); ++i) {
    ASSERT_NEAR(mpu.colours[i].x, ref.colours[i].x, 1e-6f);
    ASSERT_NEAR(mpu.colours[i].y, ref.colours[i].y, 1e-6f);
    ASSERT_NEAR(mpu.colours[i].z, ref.colours[i].z, 1e-6f);
  }
}

struct Case {
  std::string name;
  blobtree::Node node;
  float cellSize;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  for (auto& [n, m] : testmodels::primitiveModels()) out.push_back({n, m, 0.06f});
  for (auto& [n, m] : testmodels::operatorModels()) out.push_back({n, m, 0.05f});
  for (auto& [n, m] : testmodels::warpModels()) out.push_back({n, m, 0.06f});
  out.push_back({"tower", testmodels::tower(), 0.12f});
  out.push_back({"random_blobs", testmodels::randomBlobs(128), 0.12f});
  out.push_back({"tiny", testmodels::tinyPrimitives(), 0.03f});
  out.push_back({"thin_shell", testmodels::thinShell(), 0.02f});
  return out;
}

TEST(MpuPolygonizer, EqualsReferenceOnEveryModel) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    const blobtree::Program program = blobtree::compile(c.node);
    const blobtree::GridSpec grid = gridAround(program, c.cellSize);
    const mesh::TriMesh ref = polygonizeReference(program, grid);
    ASSERT_GT(ref.triangleCount(), 0u);
    // Tape pruning and the sparse field cache (octree leaves of 2, 3 and the default 4 cells),
    // each alone and together.
    for (const auto& [prune, subBlock] :
         {std::pair{false, 0}, std::pair{true, 0}, std::pair{true, 3}, std::pair{false, 2},
          std::pair{true, kDefaultSubBlockCells}}) {
      for (int D : {4, 7, 16}) {
        SCOPED_TRACE("D=" + std::to_string(D) + " prune=" + std::to_string(prune) +
                     " subBlock=" + std::to_string(subBlock));
        MpuOptions o;
        o.mpuCells = D;
        o.pruneTapes = prune;
        o.subBlockCells = subBlock;
        MpuStats st;
        mesh::TriMesh m;
        ASSERT_NO_THROW(m = polygonizeMpu(program, grid, o, &st));
        expectSameMesh(m, ref, c.cellSize);
        EXPECT_EQ(st.triangles, ref.triangleCount());
        EXPECT_EQ(st.mpus, st.discardedEmpty + st.discardedFull + st.empty + st.full + st.crossed);
      }
    }
  }
}

// MPUs whose point rows pass 64 bits, so the inside and crossing masks use both words: with
// 64 cells along x and D = 64 one MPU owns rows of 65 points (crossing edges at bit 64); with 70
// cells, D = 63 and 64 split the rows between two MPUs. Also the whole-mesh defaults (24 cells,
// leaves of 3). Deferred corners cross MPU faces in every direction.
TEST(MpuPolygonizer, WideMpusAndWholeMeshDefaultsEqualReference) {
  const std::vector<std::pair<std::string, blobtree::Node>> models = {
      {"tower", testmodels::tower()}, {"random_blobs", testmodels::randomBlobs(128)}, {"thin_shell", testmodels::thinShell()}};
  for (const auto& [name, node] : models) {
    const blobtree::Program program = blobtree::compile(node);
    ASSERT_TRUE(program.bounds.finite());
    for (int cellsX : {64, 70}) {
      SCOPED_TRACE(name + " cells.x=" + std::to_string(cellsX));
      const float cellSize = (program.bounds.hi.x - program.bounds.lo.x) / float(cellsX - 2);
      blobtree::GridSpec grid = gridAround(program, cellSize);
      grid.cells.x = cellsX;  // the same grid for both polygonizers, whatever it cuts off
      const mesh::TriMesh ref = polygonizeReference(program, grid);
      ASSERT_GT(ref.triangleCount(), 1000u);
      for (const auto& [D, subBlock] : {std::pair{63, 3}, std::pair{64, 0}, std::pair{64, 4},
                                        std::pair{kWholeMeshMpuCells, kWholeMeshSubBlockCells}}) {
        SCOPED_TRACE("D=" + std::to_string(D) + " subBlock=" + std::to_string(subBlock));
        MpuOptions o;
        o.mpuCells = D;
        o.subBlockCells = subBlock;
        o.threads = 2;
        expectSameMesh(polygonizeMpu(program, grid, o), ref, cellSize);
      }
    }
  }
}

TEST(MpuPolygonizer, ByteIdenticalForOneTwoThreeThreads) {
  const blobtree::Program program = blobtree::compile(testmodels::randomBlobs(128));
  const blobtree::GridSpec grid = gridAround(program, 0.1f);
  MpuOptions o;
  o.mpuCells = 8;
  o.threads = 1;
  const mesh::TriMesh one = polygonizeMpu(program, grid, o);
  ASSERT_GT(one.triangleCount(), 1000u);
  for (int t : {2, 3}) {
    o.threads = t;
    EXPECT_TRUE(polygonizeMpu(program, grid, o) == one) << t << " threads";
  }
}

TEST(MpuPolygonizer, RefinementMatchesReference) {
  const blobtree::Program program = blobtree::compile(testmodels::warpModels()[0].second);
  const blobtree::GridSpec grid = gridAround(program, 0.08f);
  ReferenceOptions ro;
  ro.refineSteps = 3;
  MpuOptions o;
  o.refineSteps = 3;
  o.mpuCells = 5;
  MpuStats st;
  expectSameMesh(polygonizeMpu(program, grid, o, &st), polygonizeReference(program, grid, ro), 0.08f);
  EXPECT_GT(st.edgeEvaluations, 0u);
}

// Every level against the reference polygonizer (not against the MPU's own scalar level): the
// SIMD fields are the reference's bits, so the meshes are equal exactly.
TEST(MpuPolygonizer, EveryScalarAndSimdLevelGivesTheReferenceMesh) {
  const blobtree::Program program = blobtree::compile(testmodels::tower());
  const blobtree::GridSpec grid = gridAround(program, 0.15f);
  const mesh::TriMesh ref = polygonizeReference(program, grid);
  ASSERT_GT(ref.triangleCount(), 0u);
  MpuOptions o;
  for (SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512}) {
    if (!simdLevelSupported(l)) continue;
    o.simd = l;
    EXPECT_TRUE(polygonizeMpu(program, grid, o) == ref) << toString(l);
  }
}

// Early discard must never drop surface: primitives far smaller than an MPU, a thin shell, and
// a blob around an MPU corner that only one grid point of each neighbouring MPU sees.
TEST(MpuPolygonizer, EarlyDiscardLosesNoSurface) {
  const float cell = 0.1f;
  blobtree::GridSpec grid;
  grid.origin = glm::vec3(-1.0f);
  grid.cellSize = cell;
  grid.cells = glm::ivec3(24);
  // MPU corners (D = 8) at -1 + 0.8 n; the blob sits just off the corner (-0.2, -0.2, -0.2)
  // with a surface radius (0.4542 * support) that barely covers the corner grid point.
  const glm::dvec3 corner(-0.2);
  const blobtree::Node graze = testmodels::op(
      blobtree::OperatorType::Union,
      {testmodels::primitive(blobtree::PrimitiveType::Point, corner + glm::dvec3(0.03), {}, 0, 0,
                             0.13),
       testmodels::primitive(blobtree::PrimitiveType::Point, {0.55, 0.5, 0.45}, {}, 0, 0, 0.3)});
  for (const blobtree::Node& node :
       {graze, testmodels::tinyPrimitives(), testmodels::thinShell()}) {
    const blobtree::Program program = blobtree::compile(node);
    const mesh::TriMesh ref = polygonizeReference(program, grid);
    ASSERT_GT(ref.triangleCount(), 0u);
    MpuOptions o;
    o.mpuCells = 8;
    MpuStats st;
    const mesh::TriMesh m = polygonizeMpu(program, grid, o, &st);
    EXPECT_TRUE(m == ref);
    EXPECT_GT(st.discardedEmpty + st.discardedFull, 0u) << "the discard never fired";
  }
}

// One MpuPolygonizer meshing again and again into one TriMesh (scratch, MPU results and output
// arrays reused): each mesh is the reference's, whatever came before it — a larger mesh, a
// smaller one, other MPU sizes, attributes switched off, an empty grid, a grid with no surface.
TEST(MpuPolygonizer, MeshingAgainIntoOneMeshEqualsReference) {
  struct Job {
    std::string name;
    blobtree::Node node;
    float cellSize;
    int mpuCells, subBlock, threads;
    bool attributes;
  };
  const std::vector<Job> jobs = {
      {"tower D24", testmodels::tower(), 0.1f, kWholeMeshMpuCells, kWholeMeshSubBlockCells, 2, true},
      {"random blobs D8", testmodels::randomBlobs(128), 0.1f, 8, 4, 1, true},
      {"thin shell D16", testmodels::thinShell(), 0.03f, 16, 4, 2, false},
      {"tower D24 again", testmodels::tower(), 0.1f, kWholeMeshMpuCells, kWholeMeshSubBlockCells, 2, true},
      {"tower coarser", testmodels::tower(), 0.15f, kWholeMeshMpuCells, kWholeMeshSubBlockCells, 1, true},
      {"random blobs D24", testmodels::randomBlobs(128), 0.1f, kWholeMeshMpuCells, kWholeMeshSubBlockCells, 2, true}};
  MpuPolygonizer polygonizer;
  mesh::TriMesh out;
  {  // A failed call leaves the object usable (the next job checks it).
    MpuOptions bad;
    bad.mpuCells = 1;
    const blobtree::Program program = blobtree::compile(testmodels::tower());
    EXPECT_THROW(polygonizer.polygonize(program, gridAround(program, 0.2f), bad, out), std::invalid_argument);
  }
  for (const Job& job : jobs) {
    SCOPED_TRACE(job.name);
    const blobtree::Program program = blobtree::compile(job.node);
    const blobtree::GridSpec grid = gridAround(program, job.cellSize);
    ReferenceOptions ro;
    ro.normals = ro.colours = job.attributes;
    const mesh::TriMesh ref = polygonizeReference(program, grid, ro);
    ASSERT_GT(ref.triangleCount(), 1000u);
    MpuOptions o;
    o.mpuCells = job.mpuCells, o.subBlockCells = job.subBlock, o.threads = job.threads;
    o.normals = o.colours = job.attributes;
    MpuStats st;
    polygonizer.polygonize(program, grid, o, out, &st);
    EXPECT_TRUE(out == ref);
    EXPECT_EQ(st.triangles, ref.triangleCount());

    // Between jobs: a grid the surface misses entirely, and an empty grid.
    blobtree::GridSpec away = grid;
    away.origin += glm::vec3(100.0f);
    away.cells = glm::ivec3(20);
    polygonizer.polygonize(program, away, o, out);
    EXPECT_EQ(out.triangleCount(), 0u);
    EXPECT_EQ(out.vertexCount(), 0u);
  }
  blobtree::GridSpec none = gridAround(blobtree::compile(testmodels::tower()), 0.1f);
  none.cells = glm::ivec3(0);
  polygonizer.polygonize(blobtree::compile(testmodels::tower()), none, {}, out);
  EXPECT_EQ(out.vertexCount(), 0u);
}

TEST(MpuPolygonizer, RejectsBadOptions) {
  const blobtree::Program program = blobtree::compile(testmodels::thinShell());
  const blobtree::GridSpec grid = gridAround(program, 0.1f);
  MpuOptions o;
  o.mpuCells = 1;
  EXPECT_THROW(polygonizeMpu(program, grid, o), std::invalid_argument);
  o.mpuCells = 8;
  o.threads = -1;
  EXPECT_THROW(polygonizeMpu(program, grid, o), std::invalid_argument);
}

}  // namespace
}  // namespace blobvk::cpu
