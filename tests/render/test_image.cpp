#include "vk/png_io.h"
#include "vk/render_image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace blobvk::testing {
namespace {

vk::Image gradient(std::uint32_t w, std::uint32_t h) {
  vk::Image img{w, h, std::vector<std::uint8_t>(std::size_t(w) * h * 4)};
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      auto* p = img.pixel(x, y);
      p[0] = std::uint8_t(x * 255 / (w - 1));
      p[1] = std::uint8_t(y * 255 / (h - 1));
      p[2] = std::uint8_t((x * 7 + y * 13) & 0xff);
      p[3] = 255;
    }
  return img;
}

TEST(Png, WritesAndDecodesTheSamePixels) {
  const auto path = std::filesystem::temp_directory_path() / "blobvk_png_roundtrip.png";
  const auto img = gradient(37, 23);
  vk::writePng(path.string(), img);
  const auto back = vk::readPng(path.string());
  EXPECT_EQ(back.width, 37u);
  EXPECT_EQ(back.height, 23u);
  EXPECT_EQ(back.rgba, img.rgba);
  std::filesystem::remove(path);
}

TEST(Png, ReadingAFileThatIsNotPngNamesIt) {
  const auto path = std::filesystem::temp_directory_path() / "blobvk_not_a.png";
  std::ofstream(path) << "hello";
  try {
    vk::readPng(path.string());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("blobvk_not_a.png"), std::string::npos);
  }
  std::filesystem::remove(path);
}

TEST(ImageCompare, IdenticalImagesHaveNoDifference) {
  const auto img = gradient(16, 16);
  const auto d = vk::compareImages(img, img, 0.01);
  EXPECT_EQ(d.maxDifference, 0.0);
  EXPECT_EQ(d.fractionOver, 0.0);
  EXPECT_TRUE(std::isinf(d.psnr));
}

TEST(ImageCompare, OneChangedPixelIsCountedAndPsnrFollowsTheMse) {
  const auto a = gradient(10, 10);
  auto b = a;
  b.pixel(3, 4)[1] = std::uint8_t(b.pixel(3, 4)[1] ^ 0x80);  // one channel off by 128
  const auto d = vk::compareImages(a, b, 0.1);
  EXPECT_NEAR(d.maxDifference, 128.0 / 255.0, 1e-9);
  EXPECT_NEAR(d.fractionOver, 0.01, 1e-12);
  const double mse = 128.0 * 128.0 / 300.0;
  EXPECT_NEAR(d.psnr, 10 * std::log10(255.0 * 255.0 / mse), 1e-9);
  EXPECT_THROW(vk::compareImages(a, gradient(10, 11), 0.1), std::invalid_argument);
}

}  // namespace
}  // namespace blobvk::testing
