// The bookkeeping passes the sparse path runs on the host on CPU devices
// (GpuPolygonizeOptions::hostPassesOnCpuDevices): exclusiveScanInPlace (vk/extract/host_scan.h)
// against std::exclusive_scan, listVerticesByTile (vk/extract/vertex_tile_lists.h) against a
// stable bucket sort and the group counts brick_vertex_tile_args.comp writes, and every
// shipped scene's mesh, with the host's scans and triangles (vk/extract/host_triangles.h) and with
// the device's, the CPU reference's and byte for
// byte the same, in one batch and in batches of a few bricks (whose next-layer offsets come from
// the scanned counts).
#include "blobvk/vk/extract/host_scan.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/vertex_tile_lists.h"
#include "both_paths.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

TEST(HostScan, MatchesTheStandardExclusiveScanAcrossChunkEdges) {
  std::mt19937 rng(7);
  // Small values, as row counts are, and large ones whose sums wrap around 2^32 as the device's do.
  for (const std::uint32_t top : {3u, 0xffffffffu}) {
    std::uniform_int_distribution<std::uint32_t> value(0, top);
    for (const std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(65535), std::size_t(65536),
                                std::size_t(65537), std::size_t(3 * 65536 + 5), std::size_t(1) << 20}) {
      std::vector<std::uint32_t> values(n);
      for (auto& v : values) v = value(rng);
      std::vector<std::uint32_t> expected(n);
      std::exclusive_scan(values.begin(), values.end(), expected.begin(), 0u);
      const std::uint32_t total = std::accumulate(values.begin(), values.end(), 0u);
      EXPECT_EQ(vk::exclusiveScanInPlace(values.data(), n), total) << n << " values up to " << top;
      EXPECT_EQ(values, expected) << n << " values up to " << top;
    }
  }
}

TEST(VertexTileLists, ListEachTilesVerticesInOrderWithTheirDispatchSizes) {
  std::mt19937 rng(11);
  const std::uint32_t workgroupSize = 64;
  for (const std::uint32_t vertices : {0u, 1u, 70000u, 300000u}) {
    for (const std::uint32_t tiles : {1u, 5u, 16u}) {
      const std::uint32_t bricks = 37;
      std::vector<std::uint32_t> brickTile(bricks);
      for (auto& t : brickTile) t = std::uniform_int_distribution<std::uint32_t>(0, tiles - 1)(rng);
      brickTile[0] = tiles - 1;
      std::vector<std::uint32_t> sources(2ull * vertices);
      for (std::uint32_t v = 0; v < vertices; ++v) {
        sources[2ull * v] = std::uniform_int_distribution<std::uint32_t>(0, bricks - 1)(rng);
        sources[2ull * v + 1] = v * 7u;  // the row word: not read
      }
      std::vector<std::vector<std::uint32_t>> expected(tiles);
      for (std::uint32_t v = 0; v < vertices; ++v) expected[brickTile[sources[2ull * v]]].push_back(v);
      std::vector<std::uint32_t> lists(vertices, ~0u), args(8ull * tiles, ~0u);
      vk::listVerticesByTile(sources.data(), vertices, brickTile.data(), tiles, workgroupSize, lists.data(), args.data());
      std::uint32_t first = 0;
      for (std::uint32_t t = 0; t < tiles; ++t) {
        const std::string what = std::to_string(vertices) + " vertices, tile " + std::to_string(t) + " of " +
                                 std::to_string(tiles);
        const std::uint32_t count = std::uint32_t(expected[t].size());
        const std::uint32_t groups = (count + workgroupSize - 1) / workgroupSize;
        EXPECT_EQ(args[8ull * t + 3], count) << what;
        EXPECT_EQ(args[8ull * t + 4], first) << what;
        const std::uint32_t x = std::min(groups, 65535u), y = x == 0 ? 0 : (groups + x - 1) / x;  // brick_vertex_tile_args.comp
        EXPECT_EQ(args[8ull * t], x) << what;
        EXPECT_EQ(args[8ull * t + 1], y) << what;
        EXPECT_EQ(args[8ull * t + 2], 1u) << what;
        EXPECT_EQ(std::vector<std::uint32_t>(lists.begin() + first, lists.begin() + first + count), expected[t]) << what;
        first += count;
      }
      EXPECT_EQ(first, vertices);
    }
  }
}

TEST_F(VulkanTest, HostAndDevicePassesGiveTheSameMeshes) {
  const bool cpuDevice = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  BothPaths paths;
  paths.base = [](const ShippedScene&) {
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;  // quick to build; the scans do not see the evaluator
    return o;
  };
  paths.change = [](vk::GpuPolygonizeOptions& o) { o.hostPassesOnCpuDevices = false; };
  paths.check = [cpuDevice](const std::string& what, const ShippedScene&, const mesh::TriMesh& reference,
                            const vk::GpuStats& host, const vk::GpuStats& onDevice) {
    // The host scanned and assembled the triangles where the device is the CPU (lavapipe maps its
    // buffers cached), and only there.
    const auto hostPasses = [](const vk::GpuStats& s) {
      return std::vector<double>{s.hostSteps.scans, s.hostSteps.rows, s.hostSteps.sources, s.hostSteps.triangles};
    };
    for (const double seconds : hostPasses(onDevice)) EXPECT_EQ(seconds, 0.0) << what;
    for (const double seconds : hostPasses(host)) {
      if (cpuDevice && !reference.triangles.empty()) {
        EXPECT_GT(seconds, 0.0) << what;
      }
      if (!cpuDevice) {
        EXPECT_EQ(seconds, 0.0) << what;
      }
    }
  };
  expectBothPathsGiveTheSameMeshes(device(), paths);
}

}  // namespace
}  // namespace blobvk::testing
