// Small text helpers shared by the scene readers (internal).
#pragma once

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>

#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_limits.h"

namespace blobvk::blobtree::detail {

// A user-provided string made safe for a one-line error message: quoted, control characters
// escaped, long strings cut.
inline std::string quotedText(std::string_view s) {
  std::string out = "'";
  std::size_t n = 0;
  for (char ch : s) {
    if (++n > 60) {
      out += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "'";
}

// Formats a double for messages: the shortest form that reads back as the same value, so a
// message never contradicts itself ("9.9999999e-07 is below 1e-06", not "1e-06 is below 1e-06").
inline std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);  // the familiar form where it is exact (0.0001, 2e+06)
  double back = 0.0;
  if (std::from_chars(buf, buf + std::strlen(buf), back).ec == std::errc() && back == v) return buf;
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

// The readers' one wording for a value below a limits:: minimum ("" when it is not below).
inline std::string belowMinimum(std::string_view what, double value, double minimum, std::string_view why = {}) {
  if (value >= minimum) return {};
  return std::string(what) + " " + number(value) + " is below " + number(minimum) + (why.empty() ? "" : ": ") + std::string(why);
}
inline constexpr std::string_view kRicciOverflow = "the Ricci blend would overflow a float";

// Whole file as bytes; SceneError when it cannot be opened or read, or holds more than
// limits::kMaxSceneBytes (a device such as /dev/zero would otherwise be read until memory ends).
inline std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path, "cannot open", std::strerror(errno));
  std::string bytes;
  constexpr std::size_t kChunk = std::size_t(1) << 20;
  while (in) {
    const std::size_t have = bytes.size();
    if (have >= limits::kMaxSceneBytes) throw SceneError(path, "", "more than 256 MiB: too large for a scene file");
    bytes.resize(have + kChunk);
    in.read(bytes.data() + have, std::streamsize(kChunk));
    bytes.resize(have + std::size_t(in.gcount()));
  }
  if (in.bad()) throw SceneError(path, "", "read error");
  return bytes;
}

}  // namespace blobvk::blobtree::detail
