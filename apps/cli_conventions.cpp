#include "cli_conventions.h"

#include "blobvk/mesh/output_place.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace blobvk::app {
namespace {
bool quietFlag = false;

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}
}  // namespace

bool quiet() { return quietFlag; }
void setQuiet(bool q) { quietFlag = q; }

const char* versionString() { return "blobvk " BLOBVK_VERSION; }

void warnEmptyMesh(const char* command, int cellsX, int cellsY, int cellsZ) {
  std::fprintf(stderr,
               "%s: warning: the mesh is empty: no surface crosses the %d x %d x %d grid (a finer --resolution, or grid "
               "bounds that hold the model?)\n",
               command, cellsX, cellsY, cellsZ);
}

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (unsigned char c : text) {
    if ((c >= 0x20 && c < 0x7f) || c == '\t') {
      out += char(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out;
}

std::string systemReason(int err) { return std::strerror(err); }

bool checkOutputFile(const std::string& path, std::initializer_list<std::string_view> extensions, bool streamable,
                     const char* what) {
  std::string known;
  for (std::string_view e : extensions) known += (known.empty() ? "" : ", ") + std::string(e);
  if (path == "-") {
    if (!streamable) throw UsageError(std::string(what) + " cannot be written to standard output ('-'); give a file name");
    return true;
  }
  const std::string ext = lowerExtension(path);
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    throw UsageError(printable(path) + ": cannot write " + what + " as '" + printable(ext.empty() ? "(no extension)" : ext) +
                     "' (supported: " + known + ")");
  }
  std::error_code ec;
  const std::filesystem::path p(path);
  if (std::filesystem::is_directory(p, ec)) throw std::runtime_error(printable(path) + ": cannot write: Is a directory");
  if (std::filesystem::exists(p, ec)) {
    if (access(path.c_str(), W_OK) != 0) throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(errno));
    return false;
  }
  const std::filesystem::path parent = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(parent, ec)) {
    const int err = std::filesystem::exists(parent, ec) ? ENOTDIR : ENOENT;
    throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(err));
  }
  if (access(parent.c_str(), W_OK | X_OK) != 0) throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(errno));
  return false;
}

void checkOutputFolder(const std::string& path) {
  if (path == "-") throw UsageError("the output is a folder of frames; '-' (standard output) is not one");
  std::error_code ec;
  std::filesystem::path p = std::filesystem::absolute(std::filesystem::path(path), ec);
  if (ec) throw std::runtime_error(printable(path) + ": cannot create the folder: " + ec.message());
  if (std::filesystem::exists(p, ec)) {
    if (!std::filesystem::is_directory(p, ec))
      throw std::runtime_error(printable(path) + ": exists and is not a folder (the output is a folder of frames)");
    if (access(p.c_str(), W_OK | X_OK) != 0) throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(errno));
    return;
  }
  // The nearest ancestor that exists is where create_directories would start.
  while (p.has_parent_path() && p.parent_path() != p && !std::filesystem::exists(p, ec)) p = p.parent_path();
  if (!std::filesystem::is_directory(p, ec)) throw std::runtime_error(printable(path) + ": cannot create the folder: " + systemReason(ENOTDIR));
  if (access(p.c_str(), W_OK | X_OK) != 0) throw std::runtime_error(printable(path) + ": cannot create the folder: " + systemReason(errno));
}

void prepareOutputFolder(const std::string& path) {
  if (path == "-") throw UsageError("the output is a folder of frames; '-' (standard output) is not one");
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw std::runtime_error(printable(path) + ": cannot create the folder: " + ec.message());
  if (!std::filesystem::is_directory(path, ec)) throw std::runtime_error(printable(path) + ": cannot create the folder: " + systemReason(EEXIST));
  if (access(path.c_str(), W_OK | X_OK) != 0) throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(errno));
}

void writeStdout(std::string_view bytes) {
  std::fflush(stdout);
  if (std::fwrite(bytes.data(), 1, bytes.size(), stdout) != bytes.size() || std::fflush(stdout) != 0) {
    throw std::runtime_error("standard output: write error: " + systemReason(errno));
  }
}

namespace {
// Truncates and writes in place: for devices and FIFOs, and where a temporary cannot be made or
// renamed (a folder not writable, a file bind-mounted into a container).
void writeInPlace(const std::string& shown, const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(printable(shown) + ": cannot write: " + systemReason(errno));
  out.write(bytes.data(), std::streamsize(bytes.size()));
  out.close();
  if (!out) throw std::runtime_error(printable(shown) + ": write error: " + systemReason(errno));
}
}  // namespace

void writeOutput(const std::string& path, std::string_view bytes) {
  if (path == "-") return writeStdout(bytes);
  const mesh::OutputPlace place = mesh::resolveOutputPlace(path);
  if (!place.replaceByRename) return writeInPlace(path, place.path, bytes);  // a device or FIFO
  // A temporary beside the file, renamed over it once whole: a full disk leaves the old file, not
  // a truncated one, and a symlink keeps pointing where it did.
  std::string temp = mesh::directoryOf(place.path) + "/.blobvk-out-XXXXXX";
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) {
    if (mesh::renameImpossible(errno)) return writeInPlace(path, place.path, bytes);
    throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(errno));
  }
  const auto fail = [&](const char* what, int err) {
    ::unlink(temp.c_str());
    throw std::runtime_error(printable(path) + ": " + what + ": " + systemReason(err));
  };
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail("write error", err);
    }
    done += std::size_t(n);
  }
  mesh::setReplacementMode(fd, place.path);
  if (::close(fd) != 0) fail("write error", errno);
  if (::rename(temp.c_str(), place.path.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    if (mesh::renameImpossible(err)) return writeInPlace(path, place.path, bytes);
    throw std::runtime_error(printable(path) + ": cannot write: " + systemReason(err));
  }
}

}  // namespace blobvk::app
