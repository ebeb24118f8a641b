#include "blobvk/vk/render/png_io.h"

#include <png.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

namespace blobvk::vk {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("PNG '" + path + "': " + what);
}

// libpng's own handlers print to stderr; these keep its message for the one error line instead
// (and say nothing of warnings).
struct PngErrors {
  std::string message;
};
void onPngError(png_structp png, png_const_charp message) {
  static_cast<PngErrors*>(png_get_error_ptr(png))->message = message ? message : "unknown error";
  png_longjmp(png, 1);
}
void onPngWarning(png_structp, png_const_charp) {}

// A file that failed half-written is removed, so no truncated image is left looking like a result;
// only a path that is itself a regular file: a symlink (/dev/stdout, a user's link) or a device is
// left alone, since removing the path would remove the link, not what was written.
void removePartial(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) std::remove(path.c_str());
}

// Appends libpng's output to a std::string (set as the write pointer). No exception may cross
// libpng's C frames: a failed append becomes libpng's error (a longjmp back to encode()).
void appendBytes(png_structp png, png_bytep data, png_size_t length) {
  bool full = false;
  try {
    static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), length);
  } catch (const std::exception&) {
    full = true;
  }
  if (full) png_error(png, "out of memory for the encoded image");
}
void noFlush(png_structp) {}

// Encodes into `out`; returns "" or libpng's message. libpng reports errors by a longjmp back to
// this frame, so nothing with a destructor may live in the frames between (libpng's and the
// callbacks', which catch their own exceptions).
std::string encode(std::string& out, const Image& image) {
  if (image.width == 0 || image.height == 0 || image.rgba.size() != std::size_t(image.width) * image.height * 4)
    return "image is empty or its pixel array has the wrong size";
  PngErrors errors;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &errors, onPngError, onPngWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return "libpng initialisation failed";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return errors.message.empty() ? "libpng failed while encoding" : errors.message;
  }
  png_set_write_fn(png, &out, appendBytes, noFlush);
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB_ALPHA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (std::uint32_t y = 0; y < image.height; ++y) png_write_row(png, const_cast<png_bytep>(image.pixel(0, y)));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return {};
}

}  // namespace

std::string encodePng(const Image& image) {
  std::string bytes;
  if (const std::string problem = encode(bytes, image); !problem.empty()) throw std::runtime_error("PNG: " + problem);
  return bytes;
}

void writePng(const std::string& path, const Image& image) {
  std::string bytes;
  if (const std::string problem = encode(bytes, image); !problem.empty()) fail(path, problem);
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) fail(path, std::string("cannot open for writing: ") + std::strerror(errno));
  // The stdio buffer reaches the file at fflush/fclose: a full disk often shows only there.
  bool ok = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size() && std::fflush(file) == 0;
  int err = errno;
  if (std::fclose(file) != 0 && ok) ok = false, err = errno;
  if (ok) return;
  removePartial(path);
  fail(path, std::string("write error: ") + std::strerror(err));
}

Image readPng(const std::string& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&img, path.c_str())) fail(path, img.message);
  img.format = PNG_FORMAT_RGBA;
  Image out;
  out.width = img.width;
  out.height = img.height;
  out.rgba.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, out.rgba.data(), 0, nullptr)) {
    const std::string message = img.message;
    png_image_free(&img);
    fail(path, message);
  }
  return out;
}

}  // namespace blobvk::vk
