// The program in uniform blocks (vk/eval/uniform_program.h): the blocks hold the program's
// records at their starts (read back against the program), a program over a
// block gets none, and the vertex kernel that interprets the gradient from them
// (brick_vertices_direct_uniform.comp) gives every shipped scene's mesh byte for byte as the one
// reading storage buffers, the CPU reference's, in one batch and in batches of a few bricks.
#include "blobvk/vk/eval/region_tape.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/eval/uniform_program.h"
#include "both_paths.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// A whole block, whose first n bytes read back are `records` (the rest is never read: the
// kernels index only the program's records).
void expectBlock(vk::Device& device, const vk::Buffer& block, const void* records, std::size_t n, const char* what) {
  ASSERT_EQ(block.size(), vk::kUniformProgramBlock) << what;
  if (n == 0) return;  // no records of this kind (tower has no warps)
  std::vector<std::uint8_t> bytes(n);
  device.download(block, bytes.data(), n);
  EXPECT_EQ(std::memcmp(bytes.data(), records, n), 0) << what;
}

TEST_F(VulkanTest, UniformProgramHoldsTheRecordsAndRefusesAProgramOverABlock) {
  const ShippedScene s = shipped("tower", 16);
  const blobtree::Program& p = s.program;
  const std::vector<vk::Buffer> blocks = vk::uploadUniformProgram(device(), p);
  ASSERT_EQ(blocks.size(), 5u);
  std::vector<layout::BoxRecord> boxes = p.boxes;
  boxes.push_back(vk::emptySkipBox());  // GpuProgram::emptyBox
  expectBlock(device(), blocks[0], p.code.data(), p.code.size() * sizeof(p.code[0]), "code");
  expectBlock(device(), blocks[1], p.primitives.data(), p.primitives.size() * sizeof(p.primitives[0]), "primitives");
  expectBlock(device(), blocks[2], p.matrices.data(), p.matrices.size() * sizeof(p.matrices[0]), "matrices");
  expectBlock(device(), blocks[3], boxes.data(), boxes.size() * sizeof(boxes[0]), "boxes");
  expectBlock(device(), blocks[4], p.warps.data(), p.warps.size() * sizeof(p.warps[0]), "warps");
  // tower_L6P8I4's 6,448 instructions are over the code block's 4,096.
  const ShippedScene large = shipped("tower_L6P8I4", 16);
  ASSERT_GT(large.program.code.size() * sizeof(large.program.code[0]), vk::kUniformProgramBlock);
  EXPECT_TRUE(vk::uploadUniformProgram(device(), large.program).empty());
}

TEST_F(VulkanTest, UniformAndStorageVertexProgramsGiveTheSameMeshes) {
  BothPaths paths;
  paths.resolution = 40;
  paths.base = [](const ShippedScene&) {
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;  // the interpreted gradient, no refinement: no samples
    return o;
  };
  paths.change = [](vk::GpuPolygonizeOptions& o) { o.uniformVertexProgram = false; };
  paths.check = [this](const std::string& what, const ShippedScene& s, const mesh::TriMesh& reference,
                       const vk::GpuStats& uniform, const vk::GpuStats& storage) {
    const bool fits = !vk::uploadUniformProgram(device(), s.program).empty();
    EXPECT_FALSE(storage.vertexUniforms) << what;
    if (!reference.triangles.empty()) {
      EXPECT_EQ(uniform.vertexUniforms, fits) << what;
    }
  };
  expectBothPathsGiveTheSameMeshes(device(), paths);
  // With refinement steps the vertex kernel samples the field: it reads the storage buffers.
  const ShippedScene s = shipped("creature", 24);
  vk::GpuPolygonizeOptions refined;
  refined.traversal = vk::Traversal::Stackless;
  refined.refineSteps = 2;
  vk::GpuStats stats;
  EXPECT_GT(vk::polygonize(device(), s.program, s.grid, refined, &stats).triangleCount(), 0u);
  EXPECT_FALSE(stats.vertexUniforms);
}

}  // namespace
}  // namespace blobvk::testing
