// Every shipped scene polygonizes into a closed, edge-manifold, consistently oriented mesh with
// positive volume, at two resolutions.
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/mesh/checks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <filesystem>
#include <string>
#include <vector>

namespace {

std::vector<std::string> shippedScenes() {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(std::string(BLOBVK_SOURCE_DIR) + "/scenes"))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The parameter's shipped scene, compiled, and its grid at `resolution` cells.
class ShippedMesh : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    scene_ = blobvk::blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + GetParam() + ".json");
    program_ = blobvk::blobtree::compile(scene_.root);
  }
  blobvk::blobtree::GridSpec gridAt(int resolution) const {
    blobvk::blobtree::GridRequest request;
    request.resolution = resolution;
    return blobvk::blobtree::chooseGrid(program_, scene_.grid, request);
  }
  blobvk::blobtree::Scene scene_;
  blobvk::blobtree::Program program_;
};

TEST_P(ShippedMesh, WatertightAtTwoResolutions) {
  using namespace blobvk;
  for (int resolution : {24, 41}) {
    const mesh::MeshReport report = mesh::checkMesh(cpu::polygonizeReference(program_, gridAt(resolution)));
    EXPECT_GT(report.triangles, 0u) << GetParam() << " at " << resolution;
    EXPECT_TRUE(report.watertight()) << GetParam() << " at " << resolution << ": " << report.summary();
    EXPECT_GT(report.volume, 0.0) << GetParam() << " at " << resolution;
    EXPECT_EQ(report.eulerCharacteristic % 2, 0) << GetParam() << ": a closed orientable surface has even V - E + F";
  }
}

// Formats without indices (STL) and tools that weld by position see a mesh whose vertices share
// positions as another mesh. No two vertices may share one: each lies strictly inside its edge
// (rule 2 keeps t 2^-12 from either end), and distinct edges' insides are disjoint. craniotomy at
// 80 and 100 cells has samples exactly at the iso value, where every crossing edge of such a point
// once put its vertex on the point (16 zero-area triangles, non-manifold once welded).
TEST_P(ShippedMesh, NoTwoVerticesShareAPosition) {
  using namespace blobvk;
  for (int resolution : {80, 100}) {
    const mesh::TriMesh m = cpu::polygonizeMpu(program_, gridAt(resolution), cpu::MpuOptions{});
    std::map<std::array<std::uint32_t, 3>, std::size_t> seen;
    std::size_t shared = 0;
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
      std::array<std::uint32_t, 3> bits{};
      std::memcpy(bits.data(), &m.positions[v], sizeof bits);
      shared += !seen.emplace(bits, v).second;
    }
    EXPECT_EQ(shared, 0u) << GetParam() << " at " << resolution;
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedMesh, ::testing::ValuesIn(shippedScenes()),
                         [](const auto& info) { return info.param; });

}  // namespace
