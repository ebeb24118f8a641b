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

#include <cstdlib>
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

TEST(KernelWarmUp, PaysOnlyOnAColdLlvmpipe) {
  vk::WarmUpSigns s;
  s.llvmpipe = true;
  EXPECT_TRUE(vk::kernelWarmUpPays(s));  // llvmpipe, Mesa's cache on, no pipeline cache file yet
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
    const vk::KernelWarmUp::Result r = warmUp.wait();
    EXPECT_FALSE(r.failed);
    EXPECT_EQ(r.dispatched, vk::programIndependentSparseKernels().size());
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
