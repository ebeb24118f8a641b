// The cold-start warm-up (vk/extract/kernel_warm_up.h): its list of program-independent kernels is
// what a sparse job really builds (a list that drifted from the extraction would compile kernels
// no job asks for, silently), its empty dispatches are valid Vulkan under synchronisation
// validation, and it starts only where it can pay (llvmpipe, Mesa's cache on, a first process).
#include "blobvk/vk/extract/kernel_warm_up.h"
#include "blobvk/vk/extract/polygonize.h"
#include "models.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <memory>
#include <vector>
#include <filesystem>
#include <optional>
#include <random>
#include <string>

namespace blobvk::testing {
namespace {

namespace fs = std::filesystem;

// A fresh device (no kernel built yet) runs one sparse job; every warm-up kernel must then be in
// its cache under the same shader and specialisation constants.
TEST_F(VulkanTest, WarmUpKernelsAreTheOnesASparseJobBuilds) {
  vk::StandaloneOptions options;
  options.validation = true;
  options.pipelineCache = "off";
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  vk::StandaloneContext fresh(options);
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

// The observer sees each kernel the device builds once, with what another device needs to build it
// again, except background builds; a kernel is marked recorded by its dispatch and executed when
// the Device::run that dispatched it has ended.
TEST_F(VulkanTest, DeviceHandsItsNewKernelsToAnObserver) {
  std::vector<vk::KernelRecipe> seen;
  device().setKernelObserver([&](vk::KernelRecipe r) { seen.push_back(std::move(r)); });
  const std::array<std::uint32_t, 1> specs{16};  // a workgroup size no other test uses
  const vk::KernelPtr k = device().kernel("brick_triangles", specs);
  device().kernel("brick_triangles", specs);  // cached: not seen again
  device().buildInBackground("warm-up-test", [&] { device().kernel("brick_rows", specs); });
  device().waitForBackgroundBuild("warm-up-test");
  device().setKernelObserver(nullptr);
  device().kernel("brick_sources", specs);  // detached
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].name, "brick_triangles");
  EXPECT_EQ(seen[0].layoutOf, "brick_triangles");
  EXPECT_EQ(seen[0].specs, std::vector<std::uint32_t>(specs.begin(), specs.end()));
  EXPECT_FALSE(seen[0].code.empty());
  EXPECT_EQ(seen[0].kernel.lock(), k);
  EXPECT_FALSE(k->recorded);
  EXPECT_FALSE(k->executed);
  vk::EmptyDispatcher empty(device());
  empty.dispatch(*k);
  EXPECT_TRUE(k->recorded);
  EXPECT_TRUE(k->executed);
}

// The job's device compiles its kernels oldest first; the warm-up takes the newest that still
// needs a copy: not gone, not run, and (once it is free) not already recorded.
TEST(KernelWarmUp, TakesTheNewestKernelTheJobHasNotReached) {
  std::vector<std::shared_ptr<vk::Kernel>> kernels;
  std::vector<vk::KernelRecipe> recipes;
  for (int i = 0; i < 5; ++i) {
    kernels.push_back(std::make_shared<vk::Kernel>());
    recipes.push_back({"k" + std::to_string(i), "brick_field", {}, {}, kernels.back()});
  }
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

// A context whose pipeline cache directory is new (the first process) on lavapipe starts the
// warm-up, which compiles every kernel on its own validated device without a message; the same
// directory after that context saved its file, or MESA_SHADER_CACHE_DISABLE, starts none.
TEST_F(VulkanTest, WarmUpStartsForAFirstProcessOnly) {
  if (device().info().name.rfind("llvmpipe", 0) != 0) GTEST_SKIP() << "the warm-up is for llvmpipe";
  const fs::path dir = fs::temp_directory_path() /
                       ("blobvk-warm-up-test-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  vk::StandaloneOptions options;
  options.validation = true;
  options.pipelineCache = dir.string();
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  {
    ScopedEnv mesa("MESA_SHADER_CACHE_DISABLE", nullptr);
    vk::StandaloneContext first(options);
    EXPECT_EQ(first.pipelineCacheBytesLoaded(), 0u);
    vk::KernelWarmUp warmUp(first, options);
    ASSERT_TRUE(warmUp.started());
    warmUp.waitUntilIdle();
    // A kernel the job's device builds (and has not dispatched) is copied.
    const vk::KernelPtr built = first.device().kernel("brick_triangles", std::array<std::uint32_t, 1>{32});
    warmUp.waitUntilIdle();
    const vk::KernelWarmUp::Result r = warmUp.wait();
    EXPECT_FALSE(r.failed);
    EXPECT_EQ(r.dispatched, vk::programIndependentSparseKernels().size());
    EXPECT_EQ(r.copied, 1u);
    EXPECT_EQ(r.validationMessages, 0u);
  }  // `first` saves its cache file
  {
    ScopedEnv mesa("MESA_SHADER_CACHE_DISABLE", nullptr);
    vk::StandaloneContext second(options);
    EXPECT_GT(second.pipelineCacheBytesLoaded(), 0u);
    vk::KernelWarmUp warmUp(second, options);
    EXPECT_FALSE(warmUp.started());
  }
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    ScopedEnv mesa("MESA_SHADER_CACHE_DISABLE", "true");
    vk::StandaloneContext cold(options);
    vk::KernelWarmUp warmUp(cold, options);
    EXPECT_FALSE(warmUp.started());
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace blobvk::testing
