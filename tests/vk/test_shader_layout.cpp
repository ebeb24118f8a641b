// Descriptor and push-constant layouts come from the shaders' SPIR-V (vk/device/shader_layout.h,
// generated at build time by spirv-cross --reflect). Checked against an independent reading of
// the SPIR-V words, and against what every pipeline's C++ side binds and pushes: a Recorder
// refuses a dispatch that disagrees with the reflected layout, so running every pipeline once
// with no error proves the C++ usage matches.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/column_sides.h"
#include "models.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/device/shader_registry.h"
#include "unrolled_code.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <map>
#include <set>
#include <string>

namespace blobvk::testing {
namespace {

// What a SPIR-V module declares, read straight from its instruction stream (spec section 2.3):
// the bindings of descriptor set 0 and the largest member offset of the push-constant block.
struct SpirvFacts {
  std::set<std::uint32_t> bindings;
  bool hasPushBlock = false;
  std::uint32_t maxPushOffset = 0;
};

SpirvFacts readSpirv(std::span<const std::uint32_t> words) {
  constexpr std::uint32_t kOpTypePointer = 32, kOpVariable = 59, kOpDecorate = 71, kOpMemberDecorate = 72;
  constexpr std::uint32_t kBinding = 33, kDescriptorSet = 34, kOffset = 35, kPushConstant = 9;
  std::map<std::uint32_t, std::uint32_t> binding, set, pointee;
  std::map<std::uint32_t, std::uint32_t> maxOffset;  // struct id -> largest member offset
  std::uint32_t pushPointer = 0;
  for (std::size_t i = 5; i < words.size();) {
    const std::uint32_t count = words[i] >> 16, op = words[i] & 0xffffu;
    const std::uint32_t* w = &words[i];
    if (op == kOpDecorate && w[2] == kBinding) binding[w[1]] = w[3];
    if (op == kOpDecorate && w[2] == kDescriptorSet) set[w[1]] = w[3];
    if (op == kOpMemberDecorate && w[3] == kOffset) maxOffset[w[1]] = std::max(maxOffset[w[1]], w[4]);
    if (op == kOpTypePointer) pointee[w[1]] = w[3];
    if (op == kOpVariable && w[3] == kPushConstant) pushPointer = w[1];
    i += std::max<std::uint32_t>(count, 1);
  }
  SpirvFacts f;
  for (const auto& [id, b] : binding) {
    if (set.count(id) && set[id] == 0) f.bindings.insert(b);
  }
  if (pushPointer) {
    f.hasPushBlock = true;
    f.maxPushOffset = maxOffset[pointee[pushPointer]];
  }
  return f;
}

TEST(ShaderLayout, EveryEmbeddedShaderHasTheLayoutItsSpirvDeclares) {
  const auto names = vk::shaderNames();
  ASSERT_EQ(vk::shaderLayouts().size(), names.size());
  for (const auto name : names) {
    const vk::ShaderLayout* layout = vk::findShaderLayout(name);
    ASSERT_NE(layout, nullptr) << name;
    const SpirvFacts facts = readSpirv(vk::shaderCode(name));
    ASSERT_EQ(layout->bindings.size(), facts.bindings.size()) << name;
    if (!facts.bindings.empty()) {
      EXPECT_EQ(*facts.bindings.rbegin(), facts.bindings.size() - 1) << name << ": bindings are 0..n-1";
    }
    EXPECT_EQ(layout->pushConstantBytes > 0, facts.hasPushBlock) << name;
    if (facts.hasPushBlock) {
      EXPECT_GT(layout->pushConstantBytes, facts.maxPushOffset) << name;
      EXPECT_LE(layout->pushConstantBytes, facts.maxPushOffset + 64) << name;
      EXPECT_LE(layout->pushConstantBytes, 128u) << name << ": Vulkan guarantees 128 bytes only";
    }
  }
  EXPECT_EQ(vk::findShaderLayout("no_such_shader"), nullptr);
  // The shader the issue found with more bindings than the old pools allowed.
  EXPECT_EQ(vk::findShaderLayout("vertices_tiled")->bindings.size(), 14u);
}

TEST_F(VulkanTest, EveryPipelinesBuffersAndPushConstantsMatchItsReflectedLayout) {
  vk::Device dev(context().host());  // a fresh Device: it records which shaders it built
  {
    // The tower tiles its field, and with tiledVertexPass its vertices (vertices_tiled binds 14
    // buffers, more than the descriptor pools used to hold per set).
    const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/tower.json");
    const auto program = blobtree::compile(scene.root);
    blobtree::GridRequest request;
    request.resolution = 36;
    const auto grid = blobtree::chooseGrid(program, {}, request);
    vk::GpuPolygonizeOptions tiled;
    tiled.traversal = vk::Traversal::Specialised;  // the tiles are the specialised code's
    tiled.maxFieldTiles = 8;
    tiled.tiledVertexPass = true;
    vk::GpuStats stats;
    EXPECT_GT(vk::polygonize(dev, program, grid, tiled, &stats).triangleCount(), 0u);
    EXPECT_GT(stats.fieldTiles, 1u);
    // The sparse vertex pass per tile, without and with the sample loop (its tile lists, counts
    // and indirect dispatches), the lists made by the device and, on CPU devices, by the host. The
    // code unrolled, as tiles' vertex kernels need, on every driver.
    const vk::CodegenOptions unrolled = unrolledCodegen(dev);
    vk::GpuPolygonizeOptions sparseTiles;
    sparseTiles.traversal = vk::Traversal::Specialised;
    sparseTiles.codegen = &unrolled;
    sparseTiles.brickCells = 8;
    sparseTiles.sparseVertexTiles = true;
    for (int refine : {0, 1}) {
      sparseTiles.refineSteps = refine;
      sparseTiles.hostPassesOnCpuDevices = refine == 1;
      EXPECT_GT(vk::polygonize(dev, program, grid, sparseTiles, &stats).triangleCount(), 0u);
      EXPECT_GT(stats.vertexTiles, 1u);
    }
  }
  const auto program = blobtree::compile(testModels()[1].root);
  blobtree::GridRequest request;
  request.resolution = 16;
  const auto grid = blobtree::chooseGrid(program, testBounds(), request);
  vk::GpuPolygonizeOptions stackBased;
  stackBased.traversal = vk::Traversal::StackBased;
  EXPECT_GT(vk::polygonize(dev, program, grid, stackBased).triangleCount(), 0u);
  vk::GpuPolygonizeOptions stackless;  // the sparse vertex kernel without the sample loop
  stackless.traversal = vk::Traversal::Stackless;
  EXPECT_GT(vk::polygonize(dev, program, grid, stackless).triangleCount(), 0u);
  {  // ... interpreting the gradient from uniform blocks (the default above) and from storage buffers
    vk::GpuPolygonizeOptions storage = stackless;
    storage.uniformVertexProgram = false;
    EXPECT_GT(vk::polygonize(dev, program, grid, storage).triangleCount(), 0u);
  }
  {  // The field pass over per-brick tapes, in uniform blocks and in a storage buffer
     // (brick_field_tapes_uniform, brick_field_tapes).
    vk::GpuPolygonizeOptions tapes = stackless;
    tapes.brickTapes = true;
    for (bool uniforms : {true, false}) {
      tapes.brickTapeUniforms = uniforms;
      EXPECT_GT(vk::polygonize(dev, program, grid, tapes).triangleCount(), 0u);
    }
  }
  if (dev.info().isLlvmpipe()) {  // Row culling: the listed rows' field and the others' inside bits
    // (brick_field_rows, brick_row_fill), with the CPU backend's bound.
    vk::GpuPolygonizeOptions rows = stackless;
    rows.brickCells = 8;
    const auto sides = std::make_shared<cpu::ColumnSides>(program);
    rows.columnSides = [sides](const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                            std::uint8_t* out) { (*sides)(x, nx, y, z, n, out); };
    EXPECT_GT(vk::polygonize(dev, program, grid, rows).triangleCount(), 0u);
  }
  {  // An edit's re-run gives its triangles' corners as edge keys (brick_triangle_keys).
    vk::GpuPolygonizeOptions small = stackless;
    small.brickCells = 4;
    vk::IncrementalExtractor inc(dev, grid, small);
    const mesh::TriMesh& all = inc.reset(program);
    ASSERT_GT(all.triangleCount(), 0u);
    const mesh::Float3 p = all.positions[all.triangles[0][0]];
    blobtree::Region near;
    near.grow({p.x, p.y, p.z}, {p.x, p.y, p.z});
    const std::size_t triangles = all.triangleCount();
    vk::IncrementalGpuStats st;
    EXPECT_EQ(inc.update(program, near, &st).triangleCount(), triangles);
    EXPECT_FALSE(st.full);
  }
  // The classification with the records in storage buffers (the default reads them as uniforms).
  EXPECT_FALSE(vk::classifyBricks(dev, program, grid, 8, false).empty());
  stackBased.sparse = false;  // the dense pipeline's kernels
  EXPECT_GT(vk::polygonize(dev, program, grid, stackBased).triangleCount(), 0u);
  EXPECT_EQ(vk::evaluateFieldOnGrid(dev, program, grid).size(), std::size_t(grid.pointCount()));
  vk::Raycaster raycaster(dev, program);
  const vk::Camera camera = vk::resolveCamera(program.bounds, std::nullopt, {}, 1.0f);
  EXPECT_EQ(raycaster.render(camera, 32, 32).rgba.size(), 32u * 32u * 4u);

  // Every compute shader in the registry was built and dispatched; on other devices than lavapipe
  // all but those of its own passes: row culling, and the vertex tapes in uniform windows
  // (vertexTapesInWindows: CPU devices).
  const std::vector<std::string> lavapipeOnly{"brick_field_rows", "brick_row_fill", "brick_vertices_direct_tapes_uniform"};
  for (const auto name : vk::shaderNames()) {
    if (std::string(name).find('.') != std::string::npos) continue;  // graphics stages
    if (!dev.info().isLlvmpipe() &&
        std::find(lavapipeOnly.begin(), lavapipeOnly.end(), std::string(name)) != lavapipeOnly.end())
      continue;
    const auto& used = dev.shadersUsed();
    EXPECT_NE(std::find(used.begin(), used.end(), std::string(name)), used.end())
        << name << " was never dispatched: add it to this test";
  }
}

TEST_F(VulkanTest, ADispatchThatDisagreesWithTheShaderIsRefused) {
  const std::array<std::uint32_t, 1> specs{64};
  const vk::KernelPtr reduce = device().kernel("scan_reduce", specs);
  ASSERT_EQ(reduce->bindings, 2u);
  vk::Buffer a = device().createBuffer(256), b = device().createBuffer(256);
  const std::array<vk::BufferRange, 1> tooFew{vk::BufferRange(a)};
  const std::array<vk::BufferRange, 2> right{vk::BufferRange(a), vk::BufferRange(b)};
  const std::array<std::uint32_t, 32> push{};
  auto expectRefused = [&](std::span<const vk::BufferRange> buffers, std::uint32_t pushBytes, const char* what) {
    try {
      device().run([&](vk::Recorder& rec) { rec.dispatch(*reduce, buffers, push.data(), pushBytes, 0); });
      ADD_FAILURE() << what << ": expected VulkanError";
    } catch (const vk::VulkanError& e) {
      EXPECT_NE(std::string(e.what()).find("scan_reduce"), std::string::npos) << e.what();
    }
  };
  expectRefused(tooFew, reduce->pushConstantBytes, "one buffer too few");
  expectRefused(right, reduce->pushConstantBytes - 4, "push constants short of the block");
  expectRefused(right, 128 + 16, "push constants past the range");
}

}  // namespace
}  // namespace blobvk::testing
