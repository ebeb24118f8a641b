// PNG files for vk::Image through libpng (8-bit RGBA, no colour management).
#pragma once

#include "blobvk/vk/render/render_image.h"

#include <string>

namespace blobvk::vk {

// Throws std::runtime_error naming the file on any I/O or encoding failure.
void writePng(const std::string& path, const Image& image);
// Reads any 8/16-bit grey/RGB(A)/palette PNG, converted to 8-bit RGBA.
Image readPng(const std::string& path);

}  // namespace blobvk::vk
