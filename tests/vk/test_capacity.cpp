// Output capacities of the emit pass (vk/extract/slab_polygonizer.h): with buffers smaller than the mesh,
// nothing is written past the capacities (guard words after them survive), what is written is
// the reference mesh's prefix, the overflow is reported, the overflowing slab leaves the indirect
// draw, and the validation layer (core and synchronisation checks, the fixture) stays silent.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "models.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/slab_polygonizer.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <vector>

namespace blobvk::testing {
namespace {

constexpr std::uint32_t kGuard = 0xdeadbeefu;

struct Emitted {
  std::vector<std::uint32_t> positions, keys, indices;  // whole buffers, guards included
  std::array<std::uint32_t, 13> args{};
  vk::EmitOverflow overflow;
};

// Classify and emit one slab into buffers of `vertexWords`/`indexWords` words filled with guards,
// telling the emit pass it may use `vertexCapacity` vertices and `triangleCapacity` triangles.
Emitted emitInto(vk::Device& device, vk::SlabPolygonizer& poly, std::uint32_t vertexCapacity,
                 std::uint32_t triangleCapacity, std::uint32_t vertexSlots, std::uint32_t triangleSlots) {
  auto guarded = [&](std::uint64_t words) {
    vk::Buffer b = device.createBuffer(words * 4);
    const std::vector<std::uint32_t> fill(words, kGuard);
    device.upload(b, fill.data(), words * 4);
    return b;
  };
  vk::Buffer positions = guarded(vertexSlots * 3ull), normals = guarded(vertexSlots * 3ull),
             colours = guarded(vertexSlots * 3ull), keys = guarded(vertexSlots), indices = guarded(triangleSlots * 3ull);
  device.run([&](vk::Recorder& rec) {
    poly.recordClassify(rec, 0, 0, 0);
    poly.recordEmit(rec, 0, 0, {positions, normals, colours, keys, indices, vertexCapacity, triangleCapacity});
    rec.hostBarrier();
  });
  Emitted e;
  e.positions.resize(vertexSlots * 3ull);
  e.keys.resize(vertexSlots);
  e.indices.resize(triangleSlots * 3ull);
  device.download(positions, e.positions.data(), e.positions.size() * 4);
  device.download(keys, e.keys.data(), e.keys.size() * 4);
  device.download(indices, e.indices.data(), e.indices.size() * 4);
  device.download(poly.drawArgs(), e.args.data(), sizeof(e.args));
  e.overflow = poly.readOverflow();
  return e;
}

class CapacityTest : public VulkanTest {
 protected:
  void SetUp() override {
    VulkanTest::SetUp();
    program_ = blobtree::compile(testModels()[1].root);  // three blended points
    blobtree::GridRequest request;
    request.resolution = 20;
    grid_ = blobtree::chooseGrid(program_, testBounds(), request);
    cpu::ReferenceOptions ro;
    ref_ = cpu::polygonizeReference(program_, grid_, ro);
    ASSERT_GT(ref_.triangleCount(), 10u);
  }
  blobtree::Program program_;
  blobtree::GridSpec grid_;
  mesh::TriMesh ref_;
};

TEST_F(CapacityTest, UndersizedBuffersAreNeverOverrunAndTheOverflowIsReported) {
  vk::SlabPolygonizer poly(device(), program_, grid_, {});
  ASSERT_EQ(poly.slabCount(), 1u);
  const auto V = std::uint32_t(ref_.vertexCount()), T = std::uint32_t(ref_.triangleCount());
  const std::uint32_t vCap = V / 3, tCap = T / 4;
  // Buffers with room for twice the mesh: everything after the capacities must stay guards.
  const Emitted e = emitInto(device(), poly, vCap, tCap, 2 * V, 2 * T);
  EXPECT_TRUE(e.overflow.vertices);
  EXPECT_TRUE(e.overflow.triangles);
  EXPECT_EQ(e.args[vk::kOverflowWord], 3u);
  EXPECT_EQ(e.args[11], V);  // the true counts stay readable, to size a second attempt
  EXPECT_EQ(e.args[12], T);
  EXPECT_EQ(e.args[0], 0u);  // the overflowing slab is not drawn
  for (std::size_t w = std::size_t(vCap) * 3; w < e.positions.size(); ++w) ASSERT_EQ(e.positions[w], kGuard) << w;
  for (std::size_t w = vCap; w < e.keys.size(); ++w) ASSERT_EQ(e.keys[w], kGuard) << w;
  for (std::size_t w = std::size_t(tCap) * 3; w < e.indices.size(); ++w) ASSERT_EQ(e.indices[w], kGuard) << w;
  // What fits is the reference mesh's prefix (vertices in edge-key order, triangles in cell order).
  for (std::uint32_t v = 0; v < vCap; ++v) {
    EXPECT_EQ(e.keys[v], ref_.edgeKeys[v]) << v;
    float p[3];
    std::memcpy(p, &e.positions[v * 3ull], 12);
    EXPECT_NEAR(p[0], ref_.positions[v].x, 1e-4f * grid_.cellSize) << v;
  }
  for (std::uint32_t t = 0; t < tCap; ++t) {
    EXPECT_EQ(e.indices[t * 3ull], ref_.triangles[t][0]) << t;
    EXPECT_EQ(e.indices[t * 3ull + 2], ref_.triangles[t][2]) << t;
  }
}

TEST_F(CapacityTest, OnlyTheSideThatDoesNotFitIsFlagged) {
  vk::SlabPolygonizer poly(device(), program_, grid_, {});
  const auto V = std::uint32_t(ref_.vertexCount()), T = std::uint32_t(ref_.triangleCount());
  const Emitted tri = emitInto(device(), poly, V, T - 1, V + 8, T + 8);
  EXPECT_FALSE(tri.overflow.vertices);
  EXPECT_TRUE(tri.overflow.triangles);
  EXPECT_EQ(tri.indices[std::size_t(T - 1) * 3], kGuard);
  const Emitted exact = emitInto(device(), poly, V, T, V + 8, T + 8);
  EXPECT_FALSE(exact.overflow);
  EXPECT_EQ(exact.args[0], 3 * T);
  for (std::size_t w = std::size_t(V) * 3; w < exact.positions.size(); ++w) ASSERT_EQ(exact.positions[w], kGuard);
  for (std::size_t w = std::size_t(T) * 3; w < exact.indices.size(); ++w) ASSERT_EQ(exact.indices[w], kGuard);
  mesh::MeshArray<std::array<std::uint32_t, 3>> tris(T);
  std::memcpy(tris.data(), exact.indices.data(), std::size_t(T) * 12);
  EXPECT_EQ(tris, ref_.triangles);
  // Zero capacity (a caller that forgot to say): nothing written, overflow reported.
  const Emitted none = emitInto(device(), poly, 0, 0, 4, 4);
  EXPECT_TRUE(none.overflow.vertices && none.overflow.triangles);
  EXPECT_EQ(none.positions, std::vector<std::uint32_t>(12, kGuard));
  EXPECT_EQ(none.indices, std::vector<std::uint32_t>(12, kGuard));
}

// The per-tile vertex pass (one indirect dispatch per field tile, each writing vertices anywhere
// in the slab's range) honours the same capacity.
TEST_F(VulkanTest, TiledVertexPassIsClampedToo) {
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/tower.json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = 28;
  const auto grid = blobtree::chooseGrid(program, scene.grid, request);
  const auto ref = cpu::polygonizeReference(program, grid, {});
  vk::GpuPolygonizeOptions options;
  options.traversal = vk::Traversal::Specialised;  // the tiles are the specialised code's
  options.tiledVertexPass = true;
  vk::SlabPolygonizer poly(device(), program, grid, options);
  ASSERT_EQ(poly.slabCount(), 1u);
  ASSERT_GT(poly.fieldTileCount(), 1u);
  const auto V = std::uint32_t(ref.vertexCount()), T = std::uint32_t(ref.triangleCount());
  const std::uint32_t vCap = V / 2;
  const Emitted e = emitInto(device(), poly, vCap, T, V + 16, T + 16);
  EXPECT_TRUE(e.overflow.vertices);
  EXPECT_FALSE(e.overflow.triangles);
  for (std::size_t w = std::size_t(vCap) * 3; w < e.positions.size(); ++w) ASSERT_EQ(e.positions[w], kGuard) << w;
  for (std::size_t w = vCap; w < e.keys.size(); ++w) ASSERT_EQ(e.keys[w], kGuard) << w;
  for (std::uint32_t v = 0; v < vCap; ++v) ASSERT_EQ(e.keys[v], ref.edgeKeys[v]) << v;
}

}  // namespace
}  // namespace blobvk::testing
