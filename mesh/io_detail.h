// Internal helpers shared by the mesh readers and writers (not installed, not part of the API).
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <charconv>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace blobvk::mesh::detail {

// Whole file as bytes; throws std::runtime_error naming the path when it cannot be read.
std::string readFileBytes(const std::string& path);
// Writes bytes to path (truncating); throws std::runtime_error naming the path on failure.
void writeFileBytes(const std::string& path, const std::string& bytes);

// "<path>: <problem>" as a std::runtime_error.
[[noreturn]] void fail(const std::string& path, const std::string& problem);

// Checks sizes and indices before writing; throws std::invalid_argument naming the writer.
void validateForWrite(const TriMesh& mesh, const char* writer);

// Shortest text that reads back as the same float (deterministic, locale-free).
inline void appendFloat(std::string& out, float v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}
inline void appendUint(std::string& out, std::uint64_t v) {
  char buf[24];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

// Little-endian raw append (the library targets little-endian hosts; see io_common.cpp).
template <class T>
void appendRaw(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// Parses a whole token as a number; false when the token is not exactly one number.
bool parseDouble(std::string_view token, double& value);
bool parseFloat(std::string_view token, float& value);
bool parseInt64(std::string_view token, long long& value);

// Lower-cased extension including the dot (".ply"), or "" when there is none.
std::string lowerExtension(const std::string& path);

// Whitespace-separated words of a text line (spaces, tabs, a trailing CR).
std::vector<std::string_view> splitWords(std::string_view line);

}  // namespace blobvk::mesh::detail
