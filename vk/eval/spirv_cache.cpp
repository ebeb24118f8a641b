#include "blobvk/vk/eval/spirv_cache.h"

#include "blobvk/vk/device/cache_file_bytes.h"

#include "blobvk/vk/eval/runtime_compiler.h"
#include "blobvk/vk/eval/shader_sources.h"

#include <glslang/build_info.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <system_error>

#ifndef BLOBVK_VERSION
#error "BLOBVK_VERSION must be defined by the build (the project version)"
#endif

namespace blobvk::vk {
namespace {

constexpr char kMagic[8] = {'B', 'L', 'O', 'B', 'V', 'K', 'S', 'V'};
constexpr std::uint32_t kFormat = 1;
constexpr std::size_t kHeaderBytes = 40;  // magic, format, words, key bytes, key hash 2, checksum
constexpr std::uint32_t kMaxWords = 64u << 20;  // 256 MB: larger is not a kernel we wrote
constexpr std::uint32_t kSpirvMagic = 0x07230203u;

std::atomic<std::uint64_t> hits{0}, compiles{0}, ignored{0};
std::atomic<bool> writeWarned{false};

// FNV-1a 64 names the file; a multiplicative hash with another constant checks the key (a
// collision of both on different text of the same length is not a practical concern).
using detail::fnv1a;
std::uint64_t secondHash(const std::string& s) {
  std::uint64_t h = 0x9e3779b97f4a7c15ull;
  for (unsigned char c : s) h = (h + c + 1) * 0xff51afd7ed558ccdull ^ (h >> 29);
  return h;
}

std::string keyText(const std::string& shaderFile, const std::map<std::string, std::string>& overrides) {
  char head[160];
  std::snprintf(head, sizeof head, "blobvk %s; glslang %d.%d.%d%s; sources %016llx; ", BLOBVK_VERSION,
                GLSLANG_VERSION_MAJOR, GLSLANG_VERSION_MINOR, GLSLANG_VERSION_PATCH, GLSLANG_VERSION_FLAVOR,
                static_cast<unsigned long long>(shaderSourcesFingerprint()));
  std::string key = head;
  key += shaderFile;
  key += '\0';
  for (const auto& [name, text] : overrides) {  // std::map: a fixed order
    key += name;
    key += '\0';
    key += text;
    key += '\0';
  }
  return key;
}

template <class T>
T load(const std::uint8_t* p) {
  return detail::loadField<T>(p);
}
template <class T>
void store(std::vector<std::uint8_t>& out, T v) {
  detail::storeField(out, v);
}
std::string hex(std::uint64_t v) { return detail::hexDigits(v, 16); }

// The words stored in `file` for `key`; empty with `problem` empty when there is no file, empty
// with `problem` set when the file is unusable.
std::vector<std::uint32_t> readCacheFile(const std::filesystem::path& file, const std::string& key,
                                         std::string& problem) {
  problem.clear();
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status)) return {};
  if (!std::filesystem::is_regular_file(status)) {
    problem = "is not a regular file";
    return {};
  }
  if (const auto size = std::filesystem::file_size(file, ec); ec || size > kHeaderBytes + 4ull * kMaxWords) {
    problem = "is too large to be a blobvk SPIR-V cache file";
    return {};
  }
  std::ifstream in(file, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) {
    problem = "cannot be read";
    return {};
  }
  if (bytes.size() < kHeaderBytes || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    problem = "is not a blobvk SPIR-V cache file (bad magic or shorter than its header)";
    return {};
  }
  if (const auto format = load<std::uint32_t>(bytes.data() + 8); format != kFormat) {
    problem = "has format " + std::to_string(format) + ", expected " + std::to_string(kFormat);
    return {};
  }
  const auto words = load<std::uint32_t>(bytes.data() + 12);
  if (words == 0 || words > kMaxWords || bytes.size() != kHeaderBytes + 4ull * words) {
    problem = "is truncated or has trailing bytes";
    return {};
  }
  if (load<std::uint64_t>(bytes.data() + 16) != key.size() || load<std::uint64_t>(bytes.data() + 24) != secondHash(key)) {
    problem = "holds the SPIR-V of another source, glslang or blobvk version";
    return {};
  }
  const std::uint8_t* payload = bytes.data() + kHeaderBytes;
  if (load<std::uint64_t>(bytes.data() + 32) != fnv1a(0xcbf29ce484222325ull, payload, 4ull * words) ||
      load<std::uint32_t>(payload) != kSpirvMagic) {
    problem = "is corrupt (checksum mismatch)";
    return {};
  }
  std::vector<std::uint32_t> code(words);
  std::memcpy(code.data(), payload, 4ull * words);
  return code;
}

void writeCacheFile(const std::filesystem::path& file, const std::string& key, const std::vector<std::uint32_t>& code) {
  std::vector<std::uint8_t> out(kMagic, kMagic + sizeof kMagic);
  store(out, kFormat);
  store(out, std::uint32_t(code.size()));
  store(out, std::uint64_t(key.size()));
  store(out, secondHash(key));
  store(out, fnv1a(0xcbf29ce484222325ull, code.data(), 4 * code.size()));
  const auto* p = reinterpret_cast<const std::uint8_t*>(code.data());
  out.insert(out.end(), p, p + 4 * code.size());

  try {
    detail::writeFileAtomically(file, out);
  } catch (const std::exception& e) {
    if (!writeWarned.exchange(true)) std::fprintf(stderr, "blobvk: warning: SPIR-V cache not written: %s\n", e.what());
  }
}

}  // namespace

SpirvCacheCounters spirvCacheCounters() { return {hits.load(), compiles.load(), ignored.load()}; }

std::filesystem::path spirvCacheFile(const std::filesystem::path& dir, const std::string& shaderFile,
                                     const std::map<std::string, std::string>& overrides) {
  const std::string key = keyText(shaderFile, overrides);
  return dir / ("spirv-" + hex(fnv1a(0xcbf29ce484222325ull, key.data(), key.size())) + ".spv");
}

std::vector<std::uint32_t> compileComputeShaderCached(const std::filesystem::path& dir, const std::string& shaderFile,
                                                      const std::map<std::string, std::string>& overrides) {
  if (dir.empty()) {
    ++compiles;
    return compileComputeShader(shaderFile, overrides);
  }
  const std::string key = keyText(shaderFile, overrides);
  const auto file = dir / ("spirv-" + hex(fnv1a(0xcbf29ce484222325ull, key.data(), key.size())) + ".spv");
  std::string problem;
  if (auto code = readCacheFile(file, key, problem); !code.empty()) {
    ++hits;
    return code;
  }
  if (!problem.empty()) {
    ++ignored;
    std::fprintf(stderr, "blobvk: warning: SPIR-V cache %s %s; ignoring it (it is rewritten)\n", file.c_str(),
                 problem.c_str());
  }
  ++compiles;
  auto code = compileComputeShader(shaderFile, overrides);
  writeCacheFile(file, key, code);
  return code;
}

}  // namespace blobvk::vk
