// PNG files for vk::Image through libpng (8-bit RGBA, no colour management).
#pragma once

#include "blobvk/vk/render/render_image.h"

#include <string>

namespace blobvk::vk {

// The PNG file's bytes (for writers that place files themselves). Throws std::runtime_error for
// an empty image or when libpng fails.
std::string encodePng(const Image& image);
// Throws std::runtime_error naming the file on any I/O or encoding failure; a regular file
// left half-written is removed.
void writePng(const std::string& path, const Image& image);
// Reads any 8/16-bit grey/RGB(A)/palette PNG, converted to 8-bit RGBA.
Image readPng(const std::string& path);

}  // namespace blobvk::vk
