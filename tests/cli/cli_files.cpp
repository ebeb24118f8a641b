#include "cli_files.h"

#include <png.h>
#include <unistd.h>

#include <cstdlib>

namespace blobvk::testing {

Rgba decodePng(const std::string& bytes) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size())) return {};
  image.format = PNG_FORMAT_RGBA;
  Rgba out;
  out.width = image.width;
  out.height = image.height;
  out.pixels.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, out.pixels.data(), 0, nullptr)) return {};
  return out;
}

std::size_t Rgba::pixelsDifferingFrom(unsigned char r, unsigned char g, unsigned char b) const {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 3 < pixels.size(); i += 4) n += pixels[i] != r || pixels[i + 1] != g || pixels[i + 2] != b;
  return n;
}

std::size_t Rgba::pixelsDifferingFrom(const Rgba& other, int tolerance) const {
  if (other.pixels.size() != pixels.size()) return pixels.size() / 4;
  std::size_t n = 0;
  for (std::size_t i = 0; i < pixels.size(); i += 4) {
    bool differs = false;
    for (int c = 0; c < 4; ++c) differs = differs || std::abs(int(pixels[i + std::size_t(c)]) - int(other.pixels[i + std::size_t(c)])) > tolerance;
    n += differs;
  }
  return n;
}

std::size_t countJsonPrimitives(const nlohmann::json& node) {
  if (node.contains("children")) {
    std::size_t n = 0;
    for (const auto& c : node["children"]) n += countJsonPrimitives(c);
    return n;
  }
  if (node.contains("child")) return countJsonPrimitives(node["child"]);
  return 1;
}

std::filesystem::path scratchDir() {
  const auto dir = std::filesystem::temp_directory_path() / ("blobvk_cli_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

std::string sourcePath(const std::string& rel) { return std::string(BLOBVK_SOURCE_DIR) + "/" + rel; }

}  // namespace blobvk::testing
