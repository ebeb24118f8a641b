#include "cli_files.h"

#include <png.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>
#include <string>
#include <system_error>

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
  // A new folder per test process, removed when it ends: one named by the pid alone outlived its
  // process, and a later process given the same pid found the files of an earlier run in it (a
  // test that expects an empty folder failed once a machine had run the suite a few hundred times).
  static const struct Scratch {
    std::filesystem::path path;
    Scratch() {
      std::string name = (std::filesystem::temp_directory_path() / "blobvk_cli_XXXXXX").string();
      if (!mkdtemp(name.data())) throw std::runtime_error("cannot create a scratch folder under " + name);
      path = name;
    }
    ~Scratch() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } scratch;
  return scratch.path;
}

std::string sourcePath(const std::string& rel) { return std::string(BLOBVK_SOURCE_DIR) + "/" + rel; }

}  // namespace blobvk::testing
