// Internal to blobvk_vk: what the on-disk caches (pipeline_cache_file, eval/spirv_cache) share —
// FNV-1a, little-endian field packing of their headers, hex names, and an atomic file write.
#pragma once

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace blobvk::vk::detail {

inline constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull;

// FNV-1a 64: detects a flipped or truncated payload; not a defence against tampering.
inline std::uint64_t fnv1a(std::uint64_t h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}

template <class T>
T loadField(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <class T>
void storeField(std::vector<std::uint8_t>& out, T v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
  out.insert(out.end(), p, p + sizeof v);
}

std::string hexDigits(std::uint64_t v, int digits);

// Writes `bytes` to a uniquely named temporary beside `file` and renames it over `file`, so a
// reader sees the old file or the new one, never a part. Throws std::runtime_error naming the
// path and the problem; the temporary is removed on failure.
void writeFileAtomically(const std::filesystem::path& file, std::span<const std::uint8_t> bytes);

}  // namespace blobvk::vk::detail
