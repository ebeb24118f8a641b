// No Vulkan driver at all: the loader is pointed at a manifest that does not exist. Each case
// runs in a death-test child so the environment change cannot leak into other tests (the loader
// reads VK_ICD_FILENAMES / VK_DRIVER_FILES when an instance is created).
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/standalone.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

void pointLoaderAtNoDriver() {
  setenv("VK_ICD_FILENAMES", "/nonexistent/blobvk_no_driver.json", 1);
  setenv("VK_DRIVER_FILES", "/nonexistent/blobvk_no_driver.json", 1);
  unsetenv("VK_ADD_DRIVER_FILES");
}

// Exit 0 only for a VulkanError; its message goes to stderr for the regex to check.
template <class F>
[[noreturn]] void runExpectingVulkanError(F&& f) {
  pointLoaderAtNoDriver();
  try {
    f();
  } catch (const blobvk::vk::VulkanError& e) {
    std::fprintf(stderr, "VulkanError: %s\n", e.what());
    std::exit(0);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "wrong exception type: %s\n", e.what());
    std::exit(2);
  }
  std::fprintf(stderr, "no exception\n");
  std::exit(3);
}

class NoDevice : public ::testing::Test {
 protected:
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

TEST_F(NoDevice, StandaloneContextNamesTheDriverPackage) {
  EXPECT_EXIT(runExpectingVulkanError([] { blobvk::vk::StandaloneContext context; }),
              ::testing::ExitedWithCode(0), "VulkanError: .*mesa-vulkan-drivers");
}

TEST_F(NoDevice, ValidatedContextFailsTheSameWay) {
  blobvk::vk::StandaloneOptions options;
  options.validation = true;
  EXPECT_EXIT(runExpectingVulkanError([&] { blobvk::vk::StandaloneContext context(options); }),
              ::testing::ExitedWithCode(0), "VulkanError: .*(mesa-vulkan-drivers|vulkan-validationlayers)");
}

TEST_F(NoDevice, ListDevicesThrows) {
  EXPECT_EXIT(runExpectingVulkanError([] { (void)blobvk::vk::listDevices(); }),
              ::testing::ExitedWithCode(0), "VulkanError: .*mesa-vulkan-drivers");
}

TEST_F(NoDevice, VulkanAvailableSaysWhy) {
  EXPECT_EXIT(
      {
        pointLoaderAtNoDriver();
        std::string why;
        const bool available = blobvk::vk::vulkanAvailable(&why);
        std::fprintf(stderr, "available=%d why=%s\n", int(available), why.c_str());
        std::exit(available ? 1 : 0);
      },
      ::testing::ExitedWithCode(0), "available=0 why=.*mesa-vulkan-drivers");
}

}  // namespace
