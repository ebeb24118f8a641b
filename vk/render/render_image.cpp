#include "blobvk/vk/render/render_image.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace blobvk::vk {

ImageDifference compareImages(const Image& a, const Image& b, double tolerance) {
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) {
    throw std::invalid_argument("compareImages: sizes differ (" + std::to_string(a.width) + "x" +
                                std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                                std::to_string(b.height) + ")");
  }
  ImageDifference d;
  const std::size_t pixels = std::size_t(a.width) * a.height;
  if (pixels == 0) return d;
  double squared = 0.0, sum = 0.0;
  std::size_t over = 0;
  int maxDiff = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    int pixelMax = 0;
    for (int c = 0; c < 3; ++c) {
      const int diff = std::abs(int(a.rgba[i * 4 + c]) - int(b.rgba[i * 4 + c]));
      pixelMax = std::max(pixelMax, diff);
      squared += double(diff) * diff;
      sum += diff;
    }
    maxDiff = std::max(maxDiff, pixelMax);
    if (pixelMax / 255.0 > tolerance) ++over;
  }
  d.maxDifference = maxDiff / 255.0;
  d.fractionOver = double(over) / double(pixels);
  d.meanDifference = sum / (3.0 * pixels * 255.0);
  const double mse = squared / (3.0 * pixels);
  d.psnr = mse == 0.0 ? std::numeric_limits<double>::infinity()
                      : 10.0 * std::log10(255.0 * 255.0 / mse);
  return d;
}

Image differenceImage(const Image& a, const Image& b, float gain) {
  compareImages(a, b, 1.0);  // size check
  Image out{a.width, a.height, std::vector<std::uint8_t>(a.rgba.size())};
  for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      const float diff = std::abs(float(a.rgba[i + c]) - float(b.rgba[i + c])) * gain;
      out.rgba[i + c] = std::uint8_t(std::min(diff, 255.0f));
    }
    out.rgba[i + 3] = 255;
  }
  return out;
}

std::uint64_t countCoveredPixels(const Image& image, const std::uint8_t background[3]) {
  std::uint64_t covered = 0;
  for (std::size_t i = 0; i + 3 < image.rgba.size(); i += 4) {
    bool differs = false;
    for (int c = 0; c < 3; ++c) differs |= std::abs(int(image.rgba[i + c]) - int(background[c])) > 1;
    covered += differs;
  }
  return covered;
}

}  // namespace blobvk::vk
