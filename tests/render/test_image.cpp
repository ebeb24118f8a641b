#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/render/render_image.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

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

// ---- PNG against the format itself (the PNG specification), not libpng against libpng --------

// CRC-32 (polynomial 0xEDB88320) as the PNG specification defines it for chunks.
std::uint32_t crc32Of(const std::string& bytes) {
  std::uint32_t crc = 0xffffffffu;
  for (unsigned char byte : bytes) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void appendBe32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out += char((v >> shift) & 0xffu);
}

std::uint32_t be32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = v << 8 | std::uint8_t(s[at + i]);
  return v;
}

std::string pngChunk(const std::string& type, const std::string& data) {
  std::string out;
  appendBe32(out, std::uint32_t(data.size()));
  out += type + data;
  appendBe32(out, crc32Of(type + data));
  return out;
}

const std::string kPngSignature("\x89PNG\r\n\x1a\n", 8);

std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A 3 x 2 RGB file made by hand: rows with filter 0 in one stored (uncompressed) deflate block.
TEST(Png, AHandMadeRgbFileDecodesToItsPixels) {
  const std::uint8_t rgb[2][3][3] = {{{255, 0, 0}, {0, 255, 0}, {0, 0, 255}}, {{10, 20, 30}, {40, 50, 60}, {255, 255, 255}}};
  std::string raw;
  for (const auto& row : rgb) {
    raw += '\0';
    for (const auto& px : row)
      for (std::uint8_t c : px) raw += char(c);
  }
  std::uint32_t a = 1, b = 0;  // Adler-32 of the uncompressed data
  for (unsigned char c : raw) a = (a + c) % 65521u, b = (b + a) % 65521u;
  std::string zlib = "\x78\x01\x01";  // zlib header, then a final stored block
  const std::uint16_t length = std::uint16_t(raw.size()), notLength = std::uint16_t(~length);
  zlib += char(length & 0xff), zlib += char(length >> 8), zlib += char(notLength & 0xff), zlib += char(notLength >> 8);
  zlib += raw;
  appendBe32(zlib, b << 16 | a);
  std::string ihdr;
  appendBe32(ihdr, 3);
  appendBe32(ihdr, 2);
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, colour type 2 (RGB), no interlace
  const auto path = std::filesystem::temp_directory_path() / "blobvk_png_by_hand.png";
  std::ofstream(path, std::ios::binary) << kPngSignature + pngChunk("IHDR", ihdr) + pngChunk("IDAT", zlib) + pngChunk("IEND", "");
  const auto img = vk::readPng(path.string());
  std::filesystem::remove(path);
  ASSERT_EQ(img.width, 3u);
  ASSERT_EQ(img.height, 2u);
  for (std::uint32_t y = 0; y < 2; ++y)
    for (std::uint32_t x = 0; x < 3; ++x) {
      for (int c = 0; c < 3; ++c) EXPECT_EQ(img.pixel(x, y)[c], rgb[y][x][c]) << x << "," << y;
      EXPECT_EQ(img.pixel(x, y)[3], 255) << "RGB reads as opaque";
    }
}

// The written file parsed by the specification: chunk CRCs, IHDR fields, and the pixels after
// inflating (zlib) and undoing each row's filter here.
TEST(Png, WrittenFileDecodesByTheSpecification) {
  const auto path = std::filesystem::temp_directory_path() / "blobvk_png_written.png";
  const auto img = gradient(37, 23);
  vk::writePng(path.string(), img);
  const std::string bytes = readBytes(path);
  std::filesystem::remove(path);
  ASSERT_GT(bytes.size(), 8u);
  ASSERT_EQ(bytes.substr(0, 8), kPngSignature);
  std::string ihdr, idat;
  std::vector<std::string> order;
  for (std::size_t at = 8; at + 12 <= bytes.size();) {
    const std::uint32_t length = be32(bytes, at);
    ASSERT_LE(at + 12 + length, bytes.size());
    const std::string type = bytes.substr(at + 4, 4), data = bytes.substr(at + 8, length);
    EXPECT_EQ(be32(bytes, at + 8 + length), crc32Of(type + data)) << type << " chunk CRC";
    if (type == "IHDR") ihdr = data;
    if (type == "IDAT") idat += data;
    order.push_back(type);
    at += 12 + length;
  }
  ASSERT_FALSE(order.empty());
  EXPECT_EQ(order.front(), "IHDR");
  EXPECT_EQ(order.back(), "IEND");
  ASSERT_EQ(ihdr.size(), 13u);
  EXPECT_EQ(be32(ihdr, 0), 37u);
  EXPECT_EQ(be32(ihdr, 4), 23u);
  EXPECT_EQ(ihdr.substr(8), std::string("\x08\x06\x00\x00\x00", 5)) << "8-bit RGBA, not interlaced";
  const std::size_t stride = 4 * 37;
  std::vector<std::uint8_t> raw(23 * (1 + stride));
  uLongf rawSize = uLongf(raw.size());
  ASSERT_EQ(uncompress(raw.data(), &rawSize, reinterpret_cast<const Bytef*>(idat.data()), uLong(idat.size())), Z_OK);
  ASSERT_EQ(rawSize, raw.size());
  std::vector<std::uint8_t> pixels(23 * stride), previous(stride, 0);
  for (std::size_t y = 0; y < 23; ++y) {
    const std::uint8_t filter = raw[y * (1 + stride)];
    ASSERT_LE(filter, 4u) << "row " << y;
    std::uint8_t* row = &pixels[y * stride];
    for (std::size_t i = 0; i < stride; ++i) {
      const int left = i >= 4 ? row[i - 4] : 0, up = previous[i], upLeft = i >= 4 ? previous[i - 4] : 0;
      int predictor = 0;
      if (filter == 1) predictor = left;
      if (filter == 2) predictor = up;
      if (filter == 3) predictor = (left + up) / 2;
      if (filter == 4) {
        const int p = left + up - upLeft, pa = std::abs(p - left), pb = std::abs(p - up), pc = std::abs(p - upLeft);
        predictor = pa <= pb && pa <= pc ? left : pb <= pc ? up : upLeft;
      }
      row[i] = std::uint8_t(raw[y * (1 + stride) + 1 + i] + predictor);
    }
    previous.assign(row, row + stride);
  }
  EXPECT_EQ(pixels, img.rgba);
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

// A silhouette moved by k pixels: over the tolerance in place, within it for a search radius of
// k or more, not for less; in both directions (a shape only one image has is still counted).
TEST(ImageCompare, DifferencesAShiftExplainsAreNotCountedWithinTheRadius) {
  const auto disc = [](int shift) {
    vk::Image img{64, 64, std::vector<std::uint8_t>(64 * 64 * 4, 255)};
    for (std::uint32_t y = 0; y < 64; ++y)
      for (std::uint32_t x = 0; x < 64; ++x) {
        const int dx = int(x) - 32 - shift, dy = int(y) - 32;
        if (dx * dx + dy * dy < 15 * 15) img.pixel(x, y)[0] = img.pixel(x, y)[1] = 40;
      }
    return img;
  };
  const vk::Image a = disc(0), b = disc(3);
  EXPECT_GT(vk::compareImages(a, b, 0.1).fractionOver, 0.01);
  EXPECT_EQ(vk::compareImagesWithin(a, b, 0.1, 0).fractionOver, vk::compareImages(a, b, 0.1).fractionOver);
  EXPECT_GT(vk::compareImagesWithin(a, b, 0.1, 2).fractionOver, 0.0);
  EXPECT_EQ(vk::compareImagesWithin(a, b, 0.1, 3).fractionOver, 0.0);
  EXPECT_EQ(vk::compareImagesWithin(a, b, 0.1, 3).maxDifference, vk::compareImages(a, b, 0.1).maxDifference);
  // A shape one image lacks is far from any match: counted whatever the radius up to its size.
  vk::Image blank{64, 64, std::vector<std::uint8_t>(64 * 64 * 4, 255)};
  EXPECT_GT(vk::compareImagesWithin(a, blank, 0.1, 8).fractionOver, 0.1);
  EXPECT_GT(vk::compareImagesWithin(blank, a, 0.1, 8).fractionOver, 0.1);
}

}  // namespace
}  // namespace blobvk::testing
