#include "blobvk/vk/device/cache_file_bytes.h"

#include <unistd.h>

#include <cstdio>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>

namespace blobvk::vk::detail {

std::string hexDigits(std::uint64_t v, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%0*llx", digits, static_cast<unsigned long long>(v));
  return buf;
}

void writeFileAtomically(const std::filesystem::path& file, std::span<const std::uint8_t> bytes) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  if (ec) throw std::runtime_error(file.parent_path().string() + ": cannot create directory: " + ec.message());
  // A name no other process or thread uses: pid plus a random suffix.
  std::random_device random;
  const auto temp = file.parent_path() /
                    (file.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" + hexDigits(random(), 8));
  {
    errno = 0;
    std::ofstream o(temp, std::ios::binary | std::ios::trunc);
    o.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    o.close();
    if (!o) {
      const int err = errno;  // what open, write or close failed with (EACCES, ENOSPC, ...)
      std::filesystem::remove(temp, ec);
      throw std::runtime_error(temp.string() + ": cannot write" + (err ? std::string(": ") + std::strerror(err) : ""));
    }
  }
  std::filesystem::rename(temp, file, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw std::runtime_error(file.string() + ": cannot replace: " + ec.message());
  }
}

}  // namespace blobvk::vk::detail
