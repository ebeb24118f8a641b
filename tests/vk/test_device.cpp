#include "vk/error.h"
#include "vk/shader_registry.h"
#include "vk/standalone.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <vector>

namespace blobvk::testing {
namespace {

class DeviceTest : public VulkanTest {};

TEST_F(DeviceTest, ListsTheDeviceTheContextUses) {
  const auto devices = vk::listDevices();
  ASSERT_FALSE(devices.empty());
  const bool found = std::any_of(devices.begin(), devices.end(), [&](const vk::DeviceInfo& d) {
    return d.name == device().info().name;
  });
  EXPECT_TRUE(found);
  EXPECT_GE(device().info().limits.maxStorageBufferRange, 1u << 20);
  EXPECT_GE(VK_API_VERSION_MINOR(device().info().apiVersion), 1u);
}

TEST_F(DeviceTest, UnknownDeviceNameIsAClearError) {
  vk::StandaloneOptions options;
  options.device = "no-such-gpu-xyz";
  try {
    vk::StandaloneContext ctx(options);
    FAIL() << "expected VulkanError";
  } catch (const vk::VulkanError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-gpu-xyz"), std::string::npos);
  }
}

TEST_F(DeviceTest, EveryShaderIsEmbeddedAsSpirv) {
  const auto names = vk::shaderNames();
  EXPECT_GE(names.size(), 8u);
  for (auto n : names) {
    const auto code = vk::shaderCode(n);
    ASSERT_GT(code.size(), 5u) << n;
    EXPECT_EQ(code[0], 0x07230203u) << n;  // SPIR-V magic
  }
  EXPECT_THROW(vk::shaderCode("missing"), vk::VulkanError);
}

TEST_F(DeviceTest, AllocatorReusesFreedSpaceAndUploadsRoundTrip) {
  std::vector<std::uint32_t> data(5000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = std::uint32_t(i * 2654435761u);
  const auto before = device().memory().bytesInUse();
  {
    std::vector<vk::Buffer> buffers;
    for (int i = 0; i < 20; ++i) buffers.push_back(device().createBuffer(data.size() * 4));
    for (auto& b : buffers) device().upload(b, data.data(), data.size() * 4);
    std::vector<std::uint32_t> back(data.size());
    device().download(buffers[7], back.data(), back.size() * 4);
    EXPECT_EQ(back, data);
    EXPECT_GT(device().memory().bytesInUse(), before);
  }
  EXPECT_EQ(device().memory().bytesInUse(), before);
}

TEST_F(DeviceTest, StagingPathRoundTrips) {
  device().setForceStaging(true);
  std::vector<float> data(1000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = float(i) * 0.25f;
  vk::Buffer b = device().createBuffer(data.size() * 4);
  EXPECT_EQ(b.mapped(), nullptr);
  device().upload(b, data.data(), data.size() * 4);
  std::vector<float> back(data.size());
  device().download(b, back.data(), back.size() * 4);
  device().setForceStaging(false);
  EXPECT_EQ(back, data);
}

}  // namespace
}  // namespace blobvk::testing
