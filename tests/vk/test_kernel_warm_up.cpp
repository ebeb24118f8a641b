// The cold-start warm-up (vk/extract/kernel_warm_up.h): its list of program-independent kernels is
// what a sparse job really builds (a list that drifted from the extraction would compile kernels
// no job asks for, silently), an empty dispatch really puts a kernel's machine code into Mesa's
// cache, the dispatches are valid Vulkan under synchronisation validation, the job's new kernels
// are handed over and copied, and it starts only where it can pay.
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/kernel_warm_up.h"
#include "blobvk/vk/extract/polygonize.h"
#include "models.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

namespace fs = std::filesystem;

struct ScopedEnv {
  std::string name;
  std::optional<std::string> old;
  ScopedEnv(const char* n, const char* value) : name(n) {
    if (const char* v = std::getenv(n)) old = v;
    if (value) setenv(n, value, 1); else unsetenv(n);
  }
  ~ScopedEnv() {
    if (old) setenv(name.c_str(), old->c_str(), 1); else unsetenv(name.c_str());
  }
};

struct TempDir {
  fs::path path;
  explicit TempDir(const char* what)
      : path(fs::temp_directory_path() /
             (std::string("blobvk-") + what + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()))) {
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::size_t files() const {
    std::size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(path)) n += e.is_regular_file();
    return n;
  }
};

vk::StandaloneOptions freshOptions(std::string pipelineCache = "off") {
  vk::StandaloneOptions options;
  options.validation = true;
  options.pipelineCache = std::move(pipelineCache);
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  return options;
}

bool onLlvmpipe(vk::Device& device) { return device.info().name.rfind("llvmpipe", 0) == 0; }

// A fresh device (no kernel built yet) runs one sparse job; every warm-up kernel must then be in
// its cache under the same shader and specialisation constants.
TEST_F(VulkanTest, WarmUpKernelsAreTheOnesASparseJobBuilds) {
  vk::StandaloneContext fresh(freshOptions());
  for (const vk::KernelRequest& k : vk::programIndependentSparseKernels())
    EXPECT_EQ(fresh.device().findKernel(k.shader, k.specs), nullptr) << k.shader;
  const auto program = blobtree::compile(testModels()[2].root);
  const blobtree::GridSpec grid = blobtree::chooseGrid(program, testBounds(), {});
  vk::GpuPolygonizeOptions o;
  o.traversal = vk::Traversal::Stackless;
  const mesh::TriMesh m = vk::polygonize(fresh.device(), program, grid, o);
  ASSERT_GT(m.triangleCount(), 0u);
  for (const vk::KernelRequest& k : vk::programIndependentSparseKernels())
    EXPECT_NE(fresh.device().findKernel(k.shader, k.specs), nullptr) << k.shader << " is not what the job built";
  EXPECT_EQ(fresh.validationMessages(), 0u);
}

// Each kernel is built and dispatched with no work group: no validation message (the fixture
// checks), every kernel counted, and a stop request ends the warm-up before the next kernel.
TEST_F(VulkanTest, EmptyDispatchesBuildEveryKernel) {
  const auto kernels = vk::programIndependentSparseKernels(32);
  EXPECT_EQ(vk::compileByEmptyDispatches(device(), kernels), kernels.size());
  for (const vk::KernelRequest& k : kernels) EXPECT_NE(device().findKernel(k.shader, k.specs), nullptr) << k.shader;
  std::atomic<bool> stop{true};
  EXPECT_EQ(vk::compileByEmptyDispatches(device(), kernels, &stop), 0u);
}

// What the whole warm-up rests on: on llvmpipe, a dispatch of no work group generates the kernel's
// machine code, which Mesa's shader cache then holds (one entry per kernel); building the pipeline
// alone does not. Counted in a cache directory of its own, written out when the context closes.
TEST_F(VulkanTest, AnEmptyDispatchPutsTheKernelsCodeInMesasCache) {
  if (!onLlvmpipe(device())) GTEST_SKIP() << "llvmpipe's code generation at first dispatch";
  const auto kernels = vk::programIndependentSparseKernels();
  TempDir built("mesa-built"), dispatched("mesa-dispatched");
  {
    ScopedEnv dir("MESA_SHADER_CACHE_DIR", built.path.c_str());
    ScopedEnv on("MESA_SHADER_CACHE_DISABLE", "false");
    vk::StandaloneContext c(freshOptions());
    for (const vk::KernelRequest& k : kernels) c.device().kernel(k.shader, k.specs);
    EXPECT_EQ(c.validationMessages(), 0u);
  }
  {
    ScopedEnv dir("MESA_SHADER_CACHE_DIR", dispatched.path.c_str());
    ScopedEnv on("MESA_SHADER_CACHE_DISABLE", "false");
    vk::StandaloneContext c(freshOptions());
    EXPECT_EQ(vk::compileByEmptyDispatches(c.device(), kernels), kernels.size());
    EXPECT_EQ(c.validationMessages(), 0u);
  }
  EXPECT_GE(dispatched.files(), built.files() + kernels.size());
}

// The observer sees each kernel the device builds once, with what another device needs to build it
// again, except background builds; a kernel is marked recorded by its dispatch and executed when
// the Device::run that dispatched it has ended.
TEST_F(VulkanTest, DeviceHandsItsNewKernelsToAnObserver) {
  vk::StandaloneContext fresh(freshOptions());
  vk::Device& device = fresh.device();
  std::vector<vk::KernelRecipe> seen;
  device.setKernelObserver([&](vk::KernelRecipe r) { seen.push_back(std::move(r)); });
  const std::array<std::uint32_t, 1> specs{16};
  const vk::KernelPtr k = device.kernel("brick_triangles", specs);
  device.kernel("brick_triangles", specs);  // cached: not seen again
  device.buildInBackground("warm-up-test", [&] { device.kernel("brick_rows", specs); });
  device.waitForBackgroundBuild("warm-up-test");
  device.setKernelObserver(nullptr);
  device.kernel("brick_sources", specs);  // detached
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].name, "brick_triangles");
  EXPECT_EQ(seen[0].layoutOf, "brick_triangles");
  EXPECT_EQ(seen[0].specs, std::vector<std::uint32_t>(specs.begin(), specs.end()));
  EXPECT_FALSE(seen[0].code.empty());
  EXPECT_EQ(seen[0].kernel.lock(), k);
  EXPECT_FALSE(k->recorded);
  EXPECT_FALSE(k->executed);
  vk::EmptyDispatcher empty(device);
  empty.dispatch(*k);
  EXPECT_TRUE(k->recorded);
  EXPECT_TRUE(k->executed);
  EXPECT_EQ(fresh.validationMessages(), 0u);
}

// The job's device compiles its kernels oldest first; the warm-up takes the newest that still
// needs a copy: not gone, not run, and (once it is free) not already recorded.
TEST(KernelWarmUp, TakesTheNewestKernelTheJobHasNotReached) {
  std::vector<std::shared_ptr<vk::Kernel>> kernels;
  std::vector<vk::KernelRecipe> recipes;
  for (int i = 0; i < 6; ++i) {
    kernels.push_back(std::make_shared<vk::Kernel>());
    recipes.push_back({"k" + std::to_string(i), "brick_field", {}, {}, kernels.back(), 0.02});
  }
  recipes[5].buildSeconds = 1.0;  // a copy would be built after the job's device compiled it
  kernels[0]->recorded = true;  // the job's device is compiling it
  kernels[1]->recorded = true;
  kernels[1]->executed = true;  // done there
  kernels[4]->recorded = true;  // recorded after the warm-up became free: both may compile it
  kernels[3].reset();           // gone
  auto r = vk::takeRecipe(recipes, false);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->name, "k4");
  r = vk::takeRecipe(recipes, false);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->name, "k2");
  r = vk::takeRecipe(recipes, false);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->name, "k0");
  EXPECT_FALSE(vk::takeRecipe(recipes, false));
  // Just free: what was recorded while it was busy is left to the job's device.
  recipes = {{"a", "brick_field", {}, {}, kernels[0]}, {"b", "brick_field", {}, {}, kernels[2]}};
  r = vk::takeRecipe(recipes, true);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->name, "b");
  EXPECT_TRUE(recipes.empty());
}

TEST(KernelWarmUp, PaysOnlyOnAColdLlvmpipe) {
  vk::WarmUpSigns s;
  s.cores = 2;
  s.llvmpipe = true;
  EXPECT_TRUE(vk::kernelWarmUpPays(s));  // llvmpipe, Mesa's cache on, no pipeline cache file yet
  vk::WarmUpSigns oneCore = s;
  oneCore.cores = 1;  // nothing idles for it to use
  EXPECT_FALSE(vk::kernelWarmUpPays(oneCore));
  vk::WarmUpSigns gpu = s;
  gpu.llvmpipe = false;  // GPU drivers compile at pipeline creation
  EXPECT_FALSE(vk::kernelWarmUpPays(gpu));
  vk::WarmUpSigns noMesaCache = s;
  noMesaCache.mesaCacheDisabled = true;  // the code could not reach the job's device
  EXPECT_FALSE(vk::kernelWarmUpPays(noMesaCache));
  vk::WarmUpSigns warm = s;
  warm.pipelineCacheLoaded = true;  // an earlier process ran: Mesa's cache is warm
  EXPECT_FALSE(vk::kernelWarmUpPays(warm));
  vk::WarmUpSigns unknown = s;
  unknown.pipelineCacheOff = true;  // nothing tells: no warm-up
  EXPECT_FALSE(vk::kernelWarmUpPays(unknown));
}

// A context whose pipeline cache directory is new (the first process) on lavapipe starts the
// warm-up, which compiles every program-independent kernel and copies the kernels the job's device
// builds (an embedded one with new constants, and a generated one), on its own validated device
// without a message; the same directory once that context has saved its file, or
// MESA_SHADER_CACHE_DISABLE, starts none.
TEST_F(VulkanTest, WarmUpStartsForAFirstProcessOnly) {
  if (!onLlvmpipe(device())) GTEST_SKIP() << "the warm-up is for llvmpipe";
  TempDir dir("warm-up"), mesa("warm-up-mesa");
  ScopedEnv mesaDir("MESA_SHADER_CACHE_DIR", mesa.path.c_str());  // never the user's cache
  const vk::StandaloneOptions options = freshOptions(dir.path.string());
  {
    ScopedEnv on("MESA_SHADER_CACHE_DISABLE", nullptr);
    vk::StandaloneContext first(options);
    EXPECT_EQ(first.pipelineCacheBytesLoaded(), 0u);
    if (vk::warmUpSigns(first).cores < 2) GTEST_SKIP() << "the warm-up needs a second core";
    vk::KernelWarmUp warmUp(first, options);
    ASSERT_TRUE(warmUp.started());
    warmUp.waitUntilIdle();
    const vk::KernelPtr embedded = first.device().kernel("brick_triangles", std::array<std::uint32_t, 1>{32});
    // One point: its kernel builds in milliseconds, far below kMaxCopyBuildSeconds.
    const auto program = blobtree::compile(testModels()[0].root);
    const vk::KernelPtr generated = vk::specialisedKernel(first.device(), program, vk::CodegenOptions{}, "brick_field", 64);
    warmUp.waitUntilIdle();
    const vk::KernelWarmUp::Result r = warmUp.wait();
    EXPECT_FALSE(r.failed);
    EXPECT_EQ(r.dispatched, vk::programIndependentSparseKernels().size());
    EXPECT_EQ(r.copied, 2u);
    EXPECT_EQ(r.validationMessages, 0u);
    EXPECT_EQ(first.validationMessages(), 0u);
  }  // `first` saves its cache file
  {
    ScopedEnv on("MESA_SHADER_CACHE_DISABLE", nullptr);
    vk::StandaloneContext second(options);
    EXPECT_GT(second.pipelineCacheBytesLoaded(), 0u);
    vk::KernelWarmUp warmUp(second, options);
    EXPECT_FALSE(warmUp.started());
  }
  fs::remove_all(dir.path);
  fs::create_directories(dir.path);
  for (const char* variable : {"MESA_SHADER_CACHE_DISABLE", "MESA_GLSL_CACHE_DISABLE"}) {
    ScopedEnv off(variable, "true");
    vk::StandaloneContext cold(options);
    vk::KernelWarmUp warmUp(cold, options);
    EXPECT_FALSE(warmUp.started()) << variable;
  }
}

}  // namespace
}  // namespace blobvk::testing
