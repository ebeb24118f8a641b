// An 8-bit RGBA image in host memory (row 0 at the top), and the per-pixel comparison used by
// the tests and `blobvk compare --images`. No Vulkan here.
#pragma once

#include <cstdint>
#include <vector>

namespace blobvk::vk {

struct Image {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4 bytes

  std::uint8_t* pixel(std::uint32_t x, std::uint32_t y) { return &rgba[(std::size_t(y) * width + x) * 4]; }
  const std::uint8_t* pixel(std::uint32_t x, std::uint32_t y) const {
    return &rgba[(std::size_t(y) * width + x) * 4];
  }
};

struct ImageDifference {
  double maxDifference = 0.0;  // largest per-channel |a - b| over all pixels, in [0, 1]
  double fractionOver = 0.0;   // pixels whose largest channel difference exceeds the tolerance
  double psnr = 0.0;           // dB over RGB; +infinity for identical images
  double meanDifference = 0.0; // mean per-channel |a - b|, in [0, 1]
};

// Compares RGB (alpha ignored). Throws std::invalid_argument when the sizes differ.
ImageDifference compareImages(const Image& a, const Image& b, double tolerance);

// As compareImages, but a pixel counts as over the tolerance only when no pixel of the other
// image within `radius` pixels (a square window) is within it, in both directions: differences a
// shift of up to `radius` pixels explains are not counted (a mesh's silhouette and creases lie
// within a grid cell of the surface a ray-cast finds). Max, mean and PSNR stay per pixel in place.
ImageDifference compareImagesWithin(const Image& a, const Image& b, double tolerance, int radius);

// |a - b| per channel scaled by `gain` (for looking at where two images differ).
Image differenceImage(const Image& a, const Image& b, float gain = 4.0f);

// Pixels whose colour differs from `background` by more than 1/255 in any channel.
std::uint64_t countCoveredPixels(const Image& image, const std::uint8_t background[3]);

}  // namespace blobvk::vk
