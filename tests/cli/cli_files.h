// Independent readers for what the CLI writes: PNG through libpng's own simplified API (not
// blobvk's writer), scene JSON walked with nlohmann, scratch folders per test process.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace blobvk::testing {

struct Rgba {
  unsigned width = 0, height = 0;
  std::vector<unsigned char> pixels;  // RGBA8, rows top to bottom; empty when not a PNG
  std::size_t pixelsDifferingFrom(unsigned char r, unsigned char g, unsigned char b) const;
  // Pixels that differ from `other` by more than `tolerance` in any channel (sizes must match).
  std::size_t pixelsDifferingFrom(const Rgba& other, int tolerance) const;
};

Rgba decodePng(const std::string& bytes);

// Leaves (primitives) of a scene's JSON tree: nodes without "children" or "child".
std::size_t countJsonPrimitives(const nlohmann::json& node);

std::filesystem::path scratchDir();  // one per test process, under the temp folder
std::string sourcePath(const std::string& rel);

}  // namespace blobvk::testing
