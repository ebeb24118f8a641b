// One validated StandaloneContext shared by the Vulkan tests (instance creation with the layer
// is slow on 2 cores). Each test asserts that it produced no validation message.
#pragma once

#include "blobvk/vk/device/standalone.h"
#include "vulkan_required.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>

namespace blobvk::testing {

class VulkanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // Lavapipe on 2 threads unless the caller picked a driver and thread count.
    setenv("VK_ICD_FILENAMES", "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json", 0);
    setenv("LP_NUM_THREADS", "2", 0);
    // Contexts a test makes itself: no pipeline cache unless ctest (or the caller) chose one.
    setenv("BLOBVK_PIPELINE_CACHE", "off", 0);
    if (context_ || !reason_.empty()) return;
    if (!vk::vulkanAvailable(&reason_)) return;
    vk::StandaloneOptions options;
    options.validation = true;
    options.pipelineCache = "off";  // never the user's cache; tests/vk/test_pipeline_cache.cpp tests it
    if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
    context_ = std::make_unique<vk::StandaloneContext>(options);
    ::testing::AddGlobalTestEnvironment(new ContextRelease);
  }

  void SetUp() override {
    if (!context_) BLOBVK_REQUIRE_VULKAN_OR_SKIP(reason_);
    messagesBefore_ = context_->validationMessages();
  }

  void TearDown() override {
    if (context_) {
      EXPECT_EQ(context_->validationMessages(), messagesBefore_)
          << "Vulkan validation reported problems (see stderr)";
    }
  }

  static vk::Device& device() { return context_->device(); }
  static vk::StandaloneContext& context() { return *context_; }

 private:
  // The shared context goes when the test run ends, not in a static destructor: a driver loaded
  // after the context's holder was constructed (NVIDIA's) has its exit handlers run first, and
  // destroying the device after them crashes the process at exit.
  class ContextRelease : public ::testing::Environment {
   public:
    void TearDown() override { context_.reset(); }
  };
  static inline std::unique_ptr<vk::StandaloneContext> context_;
  static inline std::string reason_;
  std::uint32_t messagesBefore_ = 0;
};

}  // namespace blobvk::testing
