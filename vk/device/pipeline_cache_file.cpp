#include "blobvk/vk/device/pipeline_cache_file.h"

#include "blobvk/vk/device/cache_file_bytes.h"

#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>

#ifndef BLOBVK_VERSION
#error "BLOBVK_VERSION must be defined by the build (the project version)"
#endif

namespace blobvk::vk {
namespace {

// blobvk's header in front of the driver's blob. Little-endian fields, as written by this host;
// a file from a machine of the other byte order fails the magic or the key and is replaced.
constexpr char kMagic[8] = {'B', 'L', 'O', 'B', 'V', 'K', 'P', 'C'};
constexpr std::uint32_t kFormat = 1;
constexpr std::size_t kHeaderBytes = 32;  // magic, format, key bytes, payload bytes, checksum
constexpr std::uint64_t kMaxPayload = 1ull << 30;  // larger is not a cache we wrote

using detail::fnv1a;
using detail::kFnvOffset;

std::uint64_t checksum(const std::string& key, std::span<const std::uint8_t> data) {
  return fnv1a(fnv1a(kFnvOffset, key.data(), key.size()), data.data(), data.size());
}

template <class T>
T load(const std::uint8_t* p) {
  return detail::loadField<T>(p);
}
template <class T>
void store(std::vector<std::uint8_t>& out, T v) {
  detail::storeField(out, v);
}
std::string hex(std::uint64_t v, int digits) { return detail::hexDigits(v, digits); }

}  // namespace

std::string PipelineCacheKey::text() const {
  std::string uuidText;
  for (std::uint8_t b : uuid) uuidText += hex(b, 2);
  std::string version;
  for (char c : blobvkVersion) version += (std::isalnum(static_cast<unsigned char>(c)) || c == '.') ? c : '_';
  return hex(vendorID, 4) + "-" + hex(deviceID, 4) + "-" + hex(driverVersion, 8) + "-" + uuidText + "-" + version;
}

PipelineCacheKey pipelineCacheKey(const VkPhysicalDeviceProperties& properties) {
  PipelineCacheKey key;
  key.vendorID = properties.vendorID;
  key.deviceID = properties.deviceID;
  key.driverVersion = properties.driverVersion;
  std::memcpy(key.uuid, properties.pipelineCacheUUID, VK_UUID_SIZE);
  key.blobvkVersion = BLOBVK_VERSION;
  return key;
}

std::filesystem::path resolvePipelineCacheDir(const std::string& option) {
  std::string value = option;
  if (value.empty()) {
    if (const char* env = std::getenv("BLOBVK_PIPELINE_CACHE"); env && *env) value = env;
  }
  if (value == "off") return {};
  if (!value.empty()) return value;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg == '/') {
    return std::filesystem::path(xdg) / "blobvk";
  }
  if (const char* home = std::getenv("HOME"); home && *home) {
    return std::filesystem::path(home) / ".cache" / "blobvk";
  }
  return {};
}

std::filesystem::path pipelineCacheFile(const std::filesystem::path& dir, const PipelineCacheKey& key) {
  return dir / ("pipelines-" + key.text() + ".bin");
}

std::vector<std::uint8_t> readPipelineCacheFile(const std::filesystem::path& file, const PipelineCacheKey& key,
                                                std::string& problem) {
  problem.clear();
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status)) return {};
  if (!std::filesystem::is_regular_file(status)) {
    problem = "is not a regular file";
    return {};
  }
  // Never read a huge file to find it is not ours.
  if (const auto size = std::filesystem::file_size(file, ec); !ec && size > kMaxPayload + 8192) {
    problem = "is too large (" + std::to_string(size) + " bytes) to be a blobvk pipeline cache";
    return {};
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    problem = "cannot be opened";
    return {};
  }
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) {
    problem = "cannot be read";
    return {};
  }
  if (bytes.size() < kHeaderBytes || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    problem = "is not a blobvk pipeline cache (bad magic or shorter than its header)";
    return {};
  }
  if (const auto format = load<std::uint32_t>(bytes.data() + 8); format != kFormat) {
    problem = "has format " + std::to_string(format) + ", expected " + std::to_string(kFormat);
    return {};
  }
  const auto keyBytes = load<std::uint32_t>(bytes.data() + 12);
  const auto payloadBytes = load<std::uint64_t>(bytes.data() + 16);
  const auto sum = load<std::uint64_t>(bytes.data() + 24);
  if (keyBytes > 4096 || payloadBytes > kMaxPayload || bytes.size() != kHeaderBytes + keyBytes + payloadBytes) {
    problem = "is truncated or has trailing bytes (" + std::to_string(bytes.size()) + " bytes, header says " +
              std::to_string(kHeaderBytes + std::uint64_t(keyBytes) + payloadBytes) + ")";
    return {};
  }
  const std::string storedKey(reinterpret_cast<const char*>(bytes.data() + kHeaderBytes), keyBytes);
  const std::span<const std::uint8_t> payload(bytes.data() + kHeaderBytes + keyBytes, payloadBytes);
  if (checksum(storedKey, payload) != sum) {
    problem = "is corrupt (checksum mismatch)";
    return {};
  }
  if (storedKey != key.text()) {
    problem = "belongs to another device, driver or blobvk version (" + storedKey + ")";
    return {};
  }
  // The driver's own header (Vulkan spec, "Pipeline Cache Header"): checked here too so that a
  // foreign blob never reaches the driver, whose validation of it is implementation-defined.
  constexpr std::size_t kVulkanHeader = 16 + VK_UUID_SIZE;
  if (payload.size() < kVulkanHeader) {
    problem = "holds no Vulkan pipeline cache header";
    return {};
  }
  const auto headerSize = load<std::uint32_t>(payload.data());
  const auto headerVersion = load<std::uint32_t>(payload.data() + 4);
  if (headerSize < kVulkanHeader || headerSize > payload.size() ||
      headerVersion != VK_PIPELINE_CACHE_HEADER_VERSION_ONE) {
    problem = "has an invalid Vulkan pipeline cache header";
    return {};
  }
  if (load<std::uint32_t>(payload.data() + 8) != key.vendorID ||
      load<std::uint32_t>(payload.data() + 12) != key.deviceID ||
      std::memcmp(payload.data() + 16, key.uuid, VK_UUID_SIZE) != 0) {
    problem = "holds pipelines of another device (vendor, device or pipelineCacheUUID differ)";
    return {};
  }
  return {payload.begin(), payload.end()};
}

void writePipelineCacheFile(const std::filesystem::path& file, const PipelineCacheKey& key,
                            std::span<const std::uint8_t> data) {
  const std::string keyText = key.text();
  std::vector<std::uint8_t> out(kMagic, kMagic + sizeof kMagic);
  store(out, kFormat);
  store(out, std::uint32_t(keyText.size()));
  store(out, std::uint64_t(data.size()));
  store(out, checksum(keyText, data));
  out.insert(out.end(), keyText.begin(), keyText.end());
  out.insert(out.end(), data.begin(), data.end());

  detail::writeFileAtomically(file, out);
}

}  // namespace blobvk::vk
