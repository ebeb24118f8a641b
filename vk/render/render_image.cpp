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

namespace {
// Whether pixel (x, y) of `a` has a pixel of `b` within `radius` whose largest channel
// difference is at most `limit` (in 0..255 steps).
bool matchesNearby(const Image& a, const Image& b, std::uint32_t x, std::uint32_t y, int radius, int limit) {
  const std::uint8_t* p = &a.rgba[(std::size_t(y) * a.width + x) * 4];
  const int y0 = std::max(0, int(y) - radius), y1 = std::min(int(b.height) - 1, int(y) + radius);
  const int x0 = std::max(0, int(x) - radius), x1 = std::min(int(b.width) - 1, int(x) + radius);
  for (int v = y0; v <= y1; ++v) {
    for (int u = x0; u <= x1; ++u) {
      const std::uint8_t* q = &b.rgba[(std::size_t(v) * b.width + std::size_t(u)) * 4];
      if (std::abs(int(p[0]) - int(q[0])) <= limit && std::abs(int(p[1]) - int(q[1])) <= limit &&
          std::abs(int(p[2]) - int(q[2])) <= limit)
        return true;
    }
  }
  return false;
}
}  // namespace

ImageDifference compareImagesWithin(const Image& a, const Image& b, double tolerance, int radius) {
  ImageDifference d = compareImages(a, b, tolerance);
  if (radius <= 0 || d.fractionOver == 0.0) return d;
  // The largest difference still within the tolerance, in 0..255 steps (pixelMax / 255 > tolerance
  // is "over" in compareImages).
  const int limit = int(std::floor(tolerance * 255.0));
  std::size_t over = 0;
  for (std::uint32_t y = 0; y < a.height; ++y)
    for (std::uint32_t x = 0; x < a.width; ++x)
      over += !matchesNearby(a, b, x, y, radius, limit) || !matchesNearby(b, a, x, y, radius, limit);
  d.fractionOver = double(over) / (double(a.width) * a.height);
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
