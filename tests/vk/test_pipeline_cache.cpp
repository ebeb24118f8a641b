// The pipeline cache: StandaloneContext's file on disk (written at destruction, read back by the
// next context, bad files ignored with one warning and replaced, "off" writes nothing) and a
// host's own VkPipelineCache (used for every pipeline, never destroyed by blobvk). Every test
// works in its own temporary directory, never in the user's cache.
#include "blobvk/vk/device/pipeline_cache_file.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    std::random_device random;
    path = fs::temp_directory_path() /
           ("blobvk-pipeline-cache-test-" + std::to_string(::getpid()) + "-" + std::to_string(random()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::vector<fs::path> files() const {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(path)) out.push_back(e.path());
    return out;
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

vk::StandaloneOptions optionsFor(const std::string& cache) {
  vk::StandaloneOptions options;
  options.validation = true;
  if (const char* d = std::getenv("BLOBVK_TEST_DEVICE")) options.device = d;
  options.pipelineCache = cache;
  return options;
}

// Builds a few pipelines (two shaders, two specialisations) so the cache has something in it.
void buildKernels(vk::Device& device) {
  for (std::uint32_t wg : {64u, 128u}) {
    const std::array<std::uint32_t, 1> spec{wg};
    ASSERT_NE(device.kernel("scan_reduce", spec), nullptr);
    ASSERT_NE(device.kernel("scan_apply", spec), nullptr);
  }
}

// The device's identity read independently of blobvk's key code, to check the stored header.
VkPhysicalDeviceProperties properties(const vk::HostContext& host) {
  auto get = reinterpret_cast<PFN_vkGetPhysicalDeviceProperties>(
      host.getInstanceProcAddr(host.instance, "vkGetPhysicalDeviceProperties"));
  VkPhysicalDeviceProperties p;
  get(host.physicalDevice, &p);
  return p;
}

// Lines of `text` that mention `needle`.
int linesMentioning(const std::string& text, const std::string& needle) {
  int n = 0;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    if (text.substr(start, end - start).find(needle) != std::string::npos) ++n;
    start = end + 1;
  }
  return n;
}

// Makes a valid cache file in `dir` (one context that builds kernels) and returns its path and
// the Vulkan data it holds.
std::pair<fs::path, std::vector<std::uint8_t>> makeCacheFile(const fs::path& dir) {
  vk::StandaloneContext ctx(optionsFor(dir.string()));
  buildKernels(ctx.device());
  EXPECT_EQ(ctx.validationMessages(), 0u);
  return {ctx.pipelineCacheFile(), ctx.device().pipelineCacheData()};
}

TEST_F(VulkanTest, ThePipelineCacheFileIsWrittenAtDestructionAndReadByTheNextContext) {
  TempDir dir;
  fs::path file;
  std::vector<std::uint8_t> data;
  {
    vk::StandaloneContext ctx(optionsFor(dir.path.string()));
    file = ctx.pipelineCacheFile();
    EXPECT_EQ(file.parent_path(), dir.path);
    EXPECT_EQ(ctx.pipelineCacheBytesLoaded(), 0u);
    buildKernels(ctx.device());
    EXPECT_FALSE(fs::exists(file)) << "written before destruction";
    data = ctx.device().pipelineCacheData();
  }
  ASSERT_TRUE(fs::exists(file));
  EXPECT_EQ(dir.files().size(), 1u) << "a temporary file was left behind";

  // The stored blob starts with the Vulkan header of this device (Vulkan spec layout).
  const auto props = properties(context().host());
  ASSERT_GE(data.size(), 32u);
  std::uint32_t header[4];
  std::memcpy(header, data.data(), sizeof header);
  EXPECT_EQ(header[1], std::uint32_t(VK_PIPELINE_CACHE_HEADER_VERSION_ONE));
  EXPECT_EQ(header[2], props.vendorID);
  EXPECT_EQ(header[3], props.deviceID);
  EXPECT_EQ(std::memcmp(data.data() + 16, props.pipelineCacheUUID, VK_UUID_SIZE), 0);
  // The file holds that blob, after blobvk's header, and names the device and the driver.
  const auto bytes = readBytes(file);
  ASSERT_GT(bytes.size(), data.size());
  EXPECT_TRUE(std::equal(data.begin(), data.end(), bytes.end() - std::ptrdiff_t(data.size())));
  char driver[16];
  std::snprintf(driver, sizeof driver, "-%08x-", props.driverVersion);
  EXPECT_NE(file.filename().string().find(driver), std::string::npos) << file;

  // A second context loads all of it, silently, and (having nothing new) leaves the file as is.
  ::testing::internal::CaptureStderr();
  {
    vk::StandaloneContext ctx(optionsFor(dir.path.string()));
    EXPECT_EQ(ctx.pipelineCacheFile(), file);
    EXPECT_EQ(ctx.pipelineCacheBytesLoaded(), data.size());
    buildKernels(ctx.device());
    EXPECT_EQ(ctx.validationMessages(), 0u);
  }
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(linesMentioning(err, "pipeline cache"), 0) << err;
  EXPECT_EQ(readBytes(file), bytes);
}

// Each way a file can be bad: ignored with exactly one warning line naming the file, the context
// works, and the file is replaced by a good one at destruction.
TEST_F(VulkanTest, ABadPipelineCacheFileGivesOneWarningAndIsReplaced) {
  TempDir dir;
  const auto [file, data] = makeCacheFile(dir.path);
  const auto good = readBytes(file);
  ASSERT_FALSE(good.empty());
  const auto props = properties(context().host());
  vk::PipelineCacheKey key = vk::pipelineCacheKey(props);

  struct Case {
    std::string name, problem;
    std::function<void()> spoil;
  };
  const std::vector<Case> cases{
      {"garbage", "not a blobvk pipeline cache", [&] { writeBytes(file, std::vector<std::uint8_t>(100, 0x5a)); }},
      {"empty", "not a blobvk pipeline cache", [&] { writeBytes(file, {}); }},
      {"truncated", "truncated",
       [&] { writeBytes(file, std::vector<std::uint8_t>(good.begin(), good.end() - 5)); }},
      {"flipped byte", "corrupt",
       [&] {
         auto b = good;
         b[b.size() - 1] ^= 0x40;
         writeBytes(file, b);
       }},
      {"other blobvk version", "another device, driver or blobvk version",
       [&] {
         auto other = key;
         other.blobvkVersion = "0.0.0-other";
         vk::writePipelineCacheFile(file, other, data);
       }},
      {"foreign UUID", "another device",
       [&] {
         auto foreign = data;
         foreign[16] ^= 0xff;  // pipelineCacheUUID[0], under a valid blobvk header
         vk::writePipelineCacheFile(file, key, foreign);
       }},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    c.spoil();
    ::testing::internal::CaptureStderr();
    {
      vk::StandaloneContext ctx(optionsFor(dir.path.string()));
      EXPECT_EQ(ctx.pipelineCacheBytesLoaded(), 0u);
      buildKernels(ctx.device());
      EXPECT_EQ(ctx.validationMessages(), 0u);
    }
    const std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(linesMentioning(err, "pipeline cache"), 1) << err;
    EXPECT_EQ(linesMentioning(err, file.string()), 1) << err;
    EXPECT_EQ(linesMentioning(err, c.problem), 1) << err;
    std::string problem;
    EXPECT_FALSE(vk::readPipelineCacheFile(file, key, problem).empty());
    EXPECT_EQ(problem, "") << "not replaced";
    EXPECT_EQ(dir.files().size(), 1u);
  }
}

// A directory where the file goes cannot be replaced: one line says it is ignored and that no
// cache is saved there (no second warning at exit), and two contexts of the process warn once.
TEST_F(VulkanTest, ADirectoryInTheCacheFilesPlaceGivesOneWarningForTheProcess) {
  TempDir dir;
  const auto [file, data] = makeCacheFile(dir.path);
  std::filesystem::remove(file);
  std::filesystem::create_directory(file);
  ::testing::internal::CaptureStderr();
  {
    vk::StandaloneContext first(optionsFor(dir.path.string()));
    vk::StandaloneContext second(optionsFor(dir.path.string()));
    buildKernels(first.device());
    buildKernels(second.device());
  }
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(linesMentioning(err, "pipeline cache"), 1) << err;
  EXPECT_EQ(linesMentioning(err, "is not a regular file; ignoring it (and not saving one there)"), 1) << err;
  EXPECT_TRUE(std::filesystem::is_directory(file));
}

TEST_F(VulkanTest, APipelineCacheSetOffWritesNothing) {
  TempDir dir;
  const char* saved = std::getenv("BLOBVK_PIPELINE_CACHE");
  const std::string previous = saved ? saved : "";
  {
    vk::StandaloneContext ctx(optionsFor("off"));
    EXPECT_TRUE(ctx.pipelineCacheFile().empty());
    buildKernels(ctx.device());
  }
  // The variable moves the cache, and "off" there turns it off, when the option is left empty.
  setenv("BLOBVK_PIPELINE_CACHE", "off", 1);
  {
    vk::StandaloneContext ctx(optionsFor(""));
    EXPECT_TRUE(ctx.pipelineCacheFile().empty());
    buildKernels(ctx.device());
  }
  EXPECT_TRUE(dir.files().empty());
  setenv("BLOBVK_PIPELINE_CACHE", dir.path.c_str(), 1);
  {
    vk::StandaloneContext ctx(optionsFor(""));
    EXPECT_EQ(ctx.pipelineCacheFile().parent_path(), dir.path);
    buildKernels(ctx.device());
  }
  EXPECT_EQ(dir.files().size(), 1u);
  // An explicit option wins over the variable.
  {
    vk::StandaloneContext ctx(optionsFor("off"));
    EXPECT_TRUE(ctx.pipelineCacheFile().empty());
  }
  if (saved) setenv("BLOBVK_PIPELINE_CACHE", previous.c_str(), 1);
  else unsetenv("BLOBVK_PIPELINE_CACHE");
}

TEST(PipelineCacheDirectory, FollowsTheXdgConventions) {
  const auto save = [](const char* name) {
    const char* v = std::getenv(name);
    return std::pair<bool, std::string>{v != nullptr, v ? v : ""};
  };
  const auto restore = [](const char* name, const std::pair<bool, std::string>& v) {
    if (v.first) setenv(name, v.second.c_str(), 1);
    else unsetenv(name);
  };
  const auto env = save("BLOBVK_PIPELINE_CACHE"), xdg = save("XDG_CACHE_HOME"), home = save("HOME");
  unsetenv("BLOBVK_PIPELINE_CACHE");
  setenv("XDG_CACHE_HOME", "/xdg/cache", 1);
  setenv("HOME", "/home/someone", 1);
  EXPECT_EQ(vk::resolvePipelineCacheDir(""), fs::path("/xdg/cache/blobvk"));
  unsetenv("XDG_CACHE_HOME");
  EXPECT_EQ(vk::resolvePipelineCacheDir(""), fs::path("/home/someone/.cache/blobvk"));
  setenv("XDG_CACHE_HOME", "relative/ignored", 1);  // the spec says relative paths are invalid
  EXPECT_EQ(vk::resolvePipelineCacheDir(""), fs::path("/home/someone/.cache/blobvk"));
  setenv("BLOBVK_PIPELINE_CACHE", "/moved", 1);
  EXPECT_EQ(vk::resolvePipelineCacheDir(""), fs::path("/moved"));
  EXPECT_EQ(vk::resolvePipelineCacheDir("/explicit"), fs::path("/explicit"));
  EXPECT_EQ(vk::resolvePipelineCacheDir("off"), fs::path());
  setenv("BLOBVK_PIPELINE_CACHE", "off", 1);
  EXPECT_EQ(vk::resolvePipelineCacheDir(""), fs::path());
  restore("BLOBVK_PIPELINE_CACHE", env);
  restore("XDG_CACHE_HOME", xdg);
  restore("HOME", home);
}

// A host's cache, seen through a spying loader: blobvk passes it to every pipeline creation and
// never destroys it. Captureless functions, so the spy state is static (one test at a time).
struct Spy {
  static inline PFN_vkGetInstanceProcAddr realGipa = nullptr;
  static inline PFN_vkGetDeviceProcAddr realGdpa = nullptr;
  static inline PFN_vkCreateComputePipelines realCreate = nullptr;
  static inline PFN_vkDestroyPipelineCache realDestroyCache = nullptr;
  static inline std::vector<VkPipelineCache> createdWith;
  static inline std::vector<VkPipelineCache> destroyed;

  static VKAPI_ATTR VkResult VKAPI_CALL create(VkDevice d, VkPipelineCache c, std::uint32_t n,
                                               const VkComputePipelineCreateInfo* i,
                                               const VkAllocationCallbacks* a, VkPipeline* p) {
    createdWith.push_back(c);
    return realCreate(d, c, n, i, a, p);
  }
  static VKAPI_ATTR void VKAPI_CALL destroyCache(VkDevice d, VkPipelineCache c, const VkAllocationCallbacks* a) {
    destroyed.push_back(c);
    realDestroyCache(d, c, a);
  }
  static VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL gdpa(VkDevice d, const char* name) {
    if (std::strcmp(name, "vkCreateComputePipelines") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&create);
    if (std::strcmp(name, "vkDestroyPipelineCache") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&destroyCache);
    return realGdpa(d, name);
  }
  static VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL gipa(VkInstance inst, const char* name) {
    if (std::strcmp(name, "vkGetDeviceProcAddr") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&gdpa);
    return realGipa(inst, name);
  }
};

TEST_F(VulkanTest, AHostPipelineCacheIsUsedForEveryPipelineAndNeverDestroyed) {
  vk::HostContext host = context().host();
  Spy::realGipa = host.getInstanceProcAddr;
  Spy::realGdpa = reinterpret_cast<PFN_vkGetDeviceProcAddr>(host.getInstanceProcAddr(host.instance, "vkGetDeviceProcAddr"));
  Spy::realCreate = reinterpret_cast<PFN_vkCreateComputePipelines>(Spy::realGdpa(host.device, "vkCreateComputePipelines"));
  Spy::realDestroyCache = reinterpret_cast<PFN_vkDestroyPipelineCache>(Spy::realGdpa(host.device, "vkDestroyPipelineCache"));
  auto createCache = reinterpret_cast<PFN_vkCreatePipelineCache>(Spy::realGdpa(host.device, "vkCreatePipelineCache"));
  auto cacheData = reinterpret_cast<PFN_vkGetPipelineCacheData>(Spy::realGdpa(host.device, "vkGetPipelineCacheData"));
  Spy::createdWith.clear();
  Spy::destroyed.clear();

  VkPipelineCacheCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
  VkPipelineCache hostCache = VK_NULL_HANDLE;
  ASSERT_EQ(createCache(host.device, &info, nullptr, &hostCache), VK_SUCCESS);
  std::size_t before = 0;
  ASSERT_EQ(cacheData(host.device, hostCache, &before, nullptr), VK_SUCCESS);

  host.pipelineCache = hostCache;
  host.getInstanceProcAddr = &Spy::gipa;
  {
    vk::Device dev(host);
    EXPECT_EQ(dev.pipelineCache(), hostCache);
    EXPECT_FALSE(dev.ownsPipelineCache());
    buildKernels(dev);
  }
  ASSERT_EQ(Spy::createdWith.size(), 4u);
  for (VkPipelineCache c : Spy::createdWith) EXPECT_EQ(c, hostCache);
  EXPECT_TRUE(Spy::destroyed.empty()) << "blobvk destroyed a pipeline cache it does not own";

  // Still alive and the host's: its data can be read (validation flags a destroyed handle).
  std::size_t after = 0;
  EXPECT_EQ(cacheData(host.device, hostCache, &after, nullptr), VK_SUCCESS);
  EXPECT_GE(after, before);
  Spy::realDestroyCache(host.device, hostCache, nullptr);

  // Without a host cache the Device makes and destroys its own.
  Spy::createdWith.clear();
  host.pipelineCache = VK_NULL_HANDLE;
  VkPipelineCache own = VK_NULL_HANDLE;
  {
    vk::Device dev(host);
    own = dev.pipelineCache();
    EXPECT_TRUE(dev.ownsPipelineCache());
    buildKernels(dev);
  }
  ASSERT_EQ(Spy::createdWith.size(), 4u);
  for (VkPipelineCache c : Spy::createdWith) EXPECT_EQ(c, own);
  ASSERT_EQ(Spy::destroyed.size(), 1u);
  EXPECT_EQ(Spy::destroyed[0], own);
}

}  // namespace
}  // namespace blobvk::testing
