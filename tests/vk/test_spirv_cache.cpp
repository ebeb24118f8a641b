// The SPIR-V cache of generated kernels (vk/eval/spirv_cache.h): a second compile of the same
// source is read back word for word what glslang makes; corrupt, truncated and foreign files give
// one warning line, are compiled again and replaced; a new StandaloneContext on the same cache
// directory builds its specialised kernels without glslang and meshes identically; glslang is
// initialised once per process whatever the threads. Every test works in its own temporary
// directory.
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/runtime_compiler.h"
#include "blobvk/vk/eval/spirv_cache.h"
#include "blobvk/vk/extract/polygonize.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace blobvk::testing {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    std::random_device random;
    path = fs::temp_directory_path() /
           ("blobvk-spirv-cache-test-" + std::to_string(::getpid()) + "-" + std::to_string(random()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::vector<std::uint8_t> readBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const fs::path& file, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

int lines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

// A generated evaluator in field_grid: the source a specialised kernel compiles.
std::map<std::string, std::string> generatedSource(int pillars) {
  const auto program = blobtree::compile(blobtree::generateTower(1, pillars, 6.0, 6.0, 1));
  return {{"eval_program.glsl", vk::generateSpecialisedEvaluator(program, vk::CodegenOptions{})}};
}

TEST(SpirvCache, TheSecondCompileIsReadBackAsGlslangMadeIt) {
  TempDir dir;
  const auto source = generatedSource(4);
  const auto direct = vk::compileComputeShader("field_grid.comp", source);
  const auto before = vk::spirvCacheCounters();
  const auto first = vk::compileComputeShaderCached(dir.path, "field_grid.comp", source);
  const auto afterFirst = vk::spirvCacheCounters();
  EXPECT_EQ(afterFirst.compiles, before.compiles + 1);
  EXPECT_EQ(afterFirst.hits, before.hits);
  ASSERT_TRUE(fs::exists(vk::spirvCacheFile(dir.path, "field_grid.comp", source)));
  const auto second = vk::compileComputeShaderCached(dir.path, "field_grid.comp", source);
  const auto afterSecond = vk::spirvCacheCounters();
  EXPECT_EQ(afterSecond.hits, afterFirst.hits + 1);
  EXPECT_EQ(afterSecond.compiles, afterFirst.compiles);
  EXPECT_EQ(first, direct);
  EXPECT_EQ(second, direct);
  // Another source (another program, another shader) is another file.
  EXPECT_NE(vk::spirvCacheFile(dir.path, "field_grid.comp", generatedSource(5)),
            vk::spirvCacheFile(dir.path, "field_grid.comp", source));
  EXPECT_NE(vk::spirvCacheFile(dir.path, "vertices.comp", source), vk::spirvCacheFile(dir.path, "field_grid.comp", source));
}

TEST(SpirvCache, ABadFileGivesOneWarningLineAndIsReplaced) {
  TempDir dir;
  const auto source = generatedSource(4);
  const auto good = vk::compileComputeShaderCached(dir.path, "field_grid.comp", source);
  const fs::path file = vk::spirvCacheFile(dir.path, "field_grid.comp", source);
  const auto valid = readBytes(file);
  ASSERT_GT(valid.size(), 100u);
  // Another source's valid file under this name: "foreign".
  const auto other = generatedSource(5);
  vk::compileComputeShaderCached(dir.path, "field_grid.comp", other);
  const auto foreign = readBytes(vk::spirvCacheFile(dir.path, "field_grid.comp", other));

  std::vector<std::uint8_t> flipped = valid;
  flipped[valid.size() / 2] ^= 0x40;
  std::vector<std::uint8_t> truncated(valid.begin(), valid.begin() + std::ptrdiff_t(valid.size() - 7));
  std::vector<std::uint8_t> garbage(333);
  std::mt19937 random(7);
  for (auto& b : garbage) b = std::uint8_t(random());
  const std::vector<std::pair<const char*, std::vector<std::uint8_t>>> cases = {
      {"corrupt", flipped}, {"truncated", truncated}, {"not a blobvk", garbage}, {"another source", foreign}, {"shorter than its header", {}}};
  for (const auto& [phrase, bytes] : cases) {
    writeBytes(file, bytes);
    const auto before = vk::spirvCacheCounters();
    ::testing::internal::CaptureStderr();
    const auto words = vk::compileComputeShaderCached(dir.path, "field_grid.comp", source);
    const std::string err = ::testing::internal::GetCapturedStderr();
    const auto after = vk::spirvCacheCounters();
    EXPECT_EQ(words, good) << phrase;
    EXPECT_EQ(lines(err), 1) << err;
    EXPECT_NE(err.find("warning: SPIR-V cache"), std::string::npos) << err;
    EXPECT_NE(err.find(file.filename().string()), std::string::npos) << err;
    EXPECT_NE(err.find(phrase), std::string::npos) << phrase << ": " << err;
    EXPECT_EQ(after.ignored, before.ignored + 1);
    EXPECT_EQ(after.compiles, before.compiles + 1);
    // Replaced: the next process (call) reads it silently.
    EXPECT_EQ(readBytes(file), valid) << phrase;
  }
}

TEST(SpirvCache, AnUnwritableDirectoryCompilesAnyway) {
  TempDir dir;
  const fs::path notADir = dir.path / "file";
  writeBytes(notADir, {1, 2, 3});
  const auto source = generatedSource(4);
  ::testing::internal::CaptureStderr();
  const auto words = vk::compileComputeShaderCached(notADir / "sub", "field_grid.comp", source);
  const auto again = vk::compileComputeShaderCached(notADir / "sub", "field_grid.comp", source);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(words, vk::compileComputeShader("field_grid.comp", source));
  EXPECT_EQ(again, words);
  EXPECT_LE(lines(err), 1) << err;  // one warning per process at most
}

TEST(SpirvCache, GlslangIsInitialisedOncePerProcessWhateverTheThreads) {
  std::vector<std::thread> threads;
  std::vector<std::vector<std::uint32_t>> words(4);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] { words[t] = vk::compileComputeShader("field_grid.comp", generatedSource(3 + t)); });
  for (auto& t : threads) t.join();
  for (const auto& w : words) EXPECT_FALSE(w.empty());
  EXPECT_EQ(vk::glslangInitialisations(), 1u);
  EXPECT_EQ(words[0], vk::compileComputeShader("field_grid.comp", generatedSource(3)));  // deterministic
  EXPECT_EQ(vk::glslangInitialisations(), 1u);
}

// A new context on a warm cache directory builds the specialised kernels without glslang, and the
// mesh is the one the cold context made.
TEST_F(VulkanTest, ANewContextOnAWarmCacheSkipsGlslangAndMeshesTheSame) {
  TempDir dir;
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  blobtree::GridRequest request;
  request.resolution = 16;
  const auto grid = blobtree::chooseGrid(program, {}, request);
  vk::GpuPolygonizeOptions options;
  options.traversal = vk::Traversal::Specialised;
  // A CPU driver's code options on every driver: the tower unrolled, so that its vertex kernel is
  // generated code too (a GPU's options loop it, and its vertex pass interprets the gradient).
  const vk::CodegenOptions codegen = vk::defaultCodegenOptions(true);
  options.codegen = &codegen;
  vk::StandaloneOptions standalone;
  standalone.validation = true;
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) standalone.device = d;
  standalone.pipelineCache = dir.path.string();
  mesh::TriMesh cold, warm;
  const auto c0 = vk::spirvCacheCounters();
  {
    vk::StandaloneContext ctx(standalone);
    cold = vk::polygonize(ctx.device(), program, grid, options);
    EXPECT_EQ(ctx.validationMessages(), 0u);
  }
  const auto c1 = vk::spirvCacheCounters();
  EXPECT_GE(c1.compiles, c0.compiles + 2);  // field and vertex kernels at least
  std::size_t spirvFiles = 0;
  for (const auto& e : fs::directory_iterator(dir.path)) spirvFiles += e.path().extension() == ".spv";
  EXPECT_EQ(spirvFiles, c1.compiles - c0.compiles);
  {
    vk::StandaloneContext ctx(standalone);
    warm = vk::polygonize(ctx.device(), program, grid, options);
    EXPECT_EQ(ctx.validationMessages(), 0u);
  }
  const auto c2 = vk::spirvCacheCounters();
  EXPECT_EQ(c2.compiles, c1.compiles);
  EXPECT_EQ(c2.hits - c1.hits, c1.compiles - c0.compiles);
  ASSERT_GT(cold.triangleCount(), 0u);
  EXPECT_TRUE(cold == warm);
}

}  // namespace
}  // namespace blobvk::testing
