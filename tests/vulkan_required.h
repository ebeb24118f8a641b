// When a test finds no Vulkan device, may it skip? Only where no Vulkan driver is installed at
// all. On a machine with lavapipe (its ICD manifest is present) a missing device is a broken
// setup, and a suite of skipped Vulkan tests must not report success: the test fails instead.
// BLOBVK_REQUIRE_VULKAN=1 makes a device mandatory anywhere (e.g. a GPU runner), =0 allows the
// skip even with lavapipe installed (a developer deliberately hiding the driver).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace blobvk::testing {

inline bool vulkanRequired() {
  if (const char* v = std::getenv("BLOBVK_REQUIRE_VULKAN")) return std::string(v) != "0";
  std::error_code error;
  for (const char* dir : {"/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"}) {
    if (!std::filesystem::is_directory(dir, error)) continue;
    for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
      if (entry.path().filename().string().rfind("lvp_icd", 0) == 0) return true;
    }
  }
  return false;
}

}  // namespace blobvk::testing

// In SetUp(): fails the test where Vulkan is required, skips it otherwise.
#define BLOBVK_REQUIRE_VULKAN_OR_SKIP(reason)                                                 \
  do {                                                                                        \
    if (::blobvk::testing::vulkanRequired()) {                                                \
      FAIL() << "no Vulkan device although lavapipe is installed (BLOBVK_REQUIRE_VULKAN=0 " \
                "allows skipping): "                                                          \
             << (reason);                                                                     \
    }                                                                                         \
    GTEST_SKIP() << "no Vulkan device: " << (reason);                                         \
  } while (false)
