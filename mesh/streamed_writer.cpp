// Streamed mesh files (see streamed_writer.h). The record encodings repeat ply.cpp's, obj.cpp's
// and stl.cpp's byte for byte; tests compare whole files against those writers.
#include "blobvk/mesh/streamed_writer.h"
#include "blobvk/mesh/io_detail.h"
#include "blobvk/mesh/output_place.h"

#include <fcntl.h>
#include <sys/sendfile.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace blobvk::mesh {
namespace {

std::string reason() { return std::strerror(errno); }

void writeAll(int fd, const char* data, std::size_t n, const std::string& what) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) throw std::runtime_error(what + ": write error: " + reason());
    data += w, n -= std::size_t(w);
  }
}

// Appends `length` bytes of `in` (from offset 0) to `out`: in the kernel where it can
// (copy_file_range between files, sendfile to a pipe or terminal), else through a buffer.
void copyAll(int in, int out, std::uint64_t length, const std::string& what) {
  off_t offset = 0;
  bool kernel = true;
  while (kernel && std::uint64_t(offset) < length) {
    const std::size_t chunk = std::size_t(std::min<std::uint64_t>(length - std::uint64_t(offset), 1u << 30));
    ssize_t n = ::copy_file_range(in, &offset, out, nullptr, chunk, 0);
    if (n < 0 && (errno == EXDEV || errno == EINVAL || errno == ENOSYS || errno == EBADF || errno == EOPNOTSUPP))
      n = ::sendfile(out, in, &offset, chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) kernel = false;
  }
  std::vector<char> buffer(1 << 20);
  while (std::uint64_t(offset) < length) {
    const ssize_t n = ::pread(in, buffer.data(), std::min<std::uint64_t>(buffer.size(), length - std::uint64_t(offset)), offset);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(what + ": cannot copy a spooled section: " + reason());
    writeAll(out, buffer.data(), std::size_t(n), what);
    offset += n;
  }
}

// Writes n bytes into `fd` at `offset`, leaving its file position alone.
void writeAllAt(int fd, const char* data, std::size_t n, std::uint64_t offset, const std::string& what) {
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, data, n, off_t(offset));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) throw std::runtime_error(what + ": write error: " + reason());
    data += w, n -= std::size_t(w), offset += std::uint64_t(w);
  }
}

// Copies `length` bytes of `in` from inOffset to `out` at outOffset, leaving both file positions
// alone (so that several threads can fill one file): in the kernel where it can, else through a
// buffer.
void copyRange(int in, std::uint64_t inOffset, int out, std::uint64_t outOffset, std::uint64_t length,
               const std::string& what) {
  off_t from = off_t(inOffset), to = off_t(outOffset);
  const off_t end = off_t(inOffset + length);
  while (from < end) {
    const std::size_t chunk = std::size_t(std::min<std::uint64_t>(std::uint64_t(end - from), 1u << 30));
    const ssize_t n = ::copy_file_range(in, &from, out, &to, chunk, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
  }
  std::vector<char> buffer(1 << 20);
  while (from < end) {
    const ssize_t n = ::pread(in, buffer.data(), std::min<std::uint64_t>(buffer.size(), std::uint64_t(end - from)), from);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(what + ": cannot copy a spooled section: " + reason());
    writeAllAt(out, buffer.data(), std::size_t(n), std::uint64_t(to), what);
    from += n, to += n;
  }
}

// One piece of a section to copy into the output at its place.
struct CopyPiece {
  int in;
  std::uint64_t from, to, length;
};

// The sections' pieces copied into `out` on a few threads: the copy is the writer's serial tail
// (about 0.9 s for a 778 MB mesh on tmpfs, one thread), when every layer is done and the cores
// that computed them are idle.
void copyPieces(const std::vector<CopyPiece>& pieces, int out, const std::string& what) {
  const unsigned threads = std::min<unsigned>(std::max(1u, std::thread::hardware_concurrency()), 4u);
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failureMutex;
  const auto work = [&] {
    for (std::size_t i; (i = next++) < pieces.size();) {
      try {
        copyRange(pieces[i].in, pieces[i].from, out, pieces[i].to, pieces[i].length, what);
      } catch (...) {
        std::lock_guard lock(failureMutex);
        if (!failure) failure = std::current_exception();
      }
    }
  };
  std::vector<std::thread> helpers;
  for (unsigned t = 1; t < threads && t < pieces.size(); ++t) helpers.emplace_back(work);
  work();
  for (auto& h : helpers) h.join();
  if (failure) std::rethrow_exception(failure);
}

// A temporary file in `dir` from mkstemp; the caller unlinks or renames it.
int makeTemporary(const std::string& dir, const std::string& stem, std::string& name) {
  name = dir + "/" + stem + "XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) throw std::runtime_error(dir + ": cannot create a temporary file: " + reason());
  return fd;
}

std::uint8_t colourByte(float c) {  // ply.cpp's toByte
  const float clamped = std::isnan(c) ? 0.0f : std::clamp(c, 0.0f, 1.0f);
  // lround without the library call: the float is below 256 with 24 significant bits, so adding
  // a half in double is exact and truncation rounds half away from zero as lround does.
  return std::uint8_t(double(clamped * 255.0f) + 0.5);
}

// Binary PLY vertex records written in place: position, normal, colour bytes (the per-value
// appends cost about as much as computing the layer's vertices on the rank that writes).
void encodeBinaryPlyVertices(std::string& out, std::span<const Float3> positions, std::span<const Float3> normals,
                             std::span<const Float3> colours, bool wantNormals, bool wantColours) {
  const std::size_t stride = 12 + (wantNormals ? 12 : 0) + (wantColours ? 3 : 0);
  out.resize(positions.size() * stride);
  char* w = out.data();
  for (std::size_t i = 0; i < positions.size(); ++i) {
    std::memcpy(w, &positions[i], 12);
    w += 12;
    if (wantNormals) {
      std::memcpy(w, &normals[i], 12);
      w += 12;
    }
    if (wantColours) {
      const Float3& c = colours[i];
      *w++ = char(colourByte(c.x)), *w++ = char(colourByte(c.y)), *w++ = char(colourByte(c.z));
    }
  }
}

void encodeBinaryPlyTriangles(std::string& out, std::span<const std::array<std::uint32_t, 3>> triangles) {
  out.resize(triangles.size() * 13);
  char* w = out.data();
  for (const auto& t : triangles) {
    *w++ = 3;
    std::memcpy(w, t.data(), 12);
    w += 12;
  }
}

void appendTriple(std::string& out, const Float3& v) {  // obj.cpp's " x y z"
  out += ' ';
  detail::appendFloat(out, v.x);
  out += ' ';
  detail::appendFloat(out, v.y);
  out += ' ';
  detail::appendFloat(out, v.z);
}

}  // namespace

// One section of the file: an unlinked temporary file written through a buffer.
class StreamedMeshFile::Spool {
 public:
  Spool(const std::string& dir, const std::string& what) : what_(what) {
    std::string name;
    fd_ = makeTemporary(dir, ".blobvk-spool-", name);
    ::unlink(name.c_str());  // gone with the process, whatever happens to it
  }
  ~Spool() { ::close(fd_); }
  Spool(const Spool&) = delete;
  Spool& operator=(const Spool&) = delete;

  void append(const std::string& bytes) {
    if (buffer_.size() + bytes.size() < kBuffer) {
      buffer_ += bytes;
      return;
    }
    flush();
    if (bytes.size() >= kBuffer) {  // a layer's worth: straight to the file, not through the buffer
      writeAll(fd_, bytes.data(), bytes.size(), what_);
      size_ += bytes.size();
    } else {
      buffer_ = bytes;
    }
  }
  void flush() {
    writeAll(fd_, buffer_.data(), buffer_.size(), what_);
    size_ += buffer_.size();
    buffer_.clear();
  }
  int fd() const { return fd_; }
  std::uint64_t size() const { return size_; }
  std::uint64_t bytes() const { return size_ + buffer_.size(); }  // written and buffered

 private:
  static constexpr std::size_t kBuffer = 4u << 20;
  std::string what_;
  int fd_ = -1;
  std::string buffer_;
  std::uint64_t size_ = 0;
};

StreamedMeshFile::StreamedMeshFile(const std::string& path, const StreamedFileOptions& options)
    : path_(path), options_(options) {
  std::string& f = options_.format;
  if (!f.empty() && f.front() == '.') f.erase(0, 1);
  std::transform(f.begin(), f.end(), f.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (f != "ply" && f != "obj" && f != "stl")
    throw std::invalid_argument("streamed mesh file: unknown format '" + options.format + "' (ply, obj or stl)");
  // The spooled sections beside the file they become (one file system, so the final copy can
  // share extents), or in TMPDIR where the output is a stream or device.
  const OutputPlace place = resolveOutputPlace(path);
  std::string dir = options_.spoolDirectory;
  if (dir.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    dir = path == "-" || !place.replaceByRename ? (tmp && *tmp ? tmp : "/tmp") : directoryOf(place.path);
  }
  const int sections = f == "stl" ? 1 : f == "ply" ? 2 : (options_.normals ? 3 : 2);
  for (int i = 0; i < sections; ++i) sections_.push_back(std::make_unique<Spool>(dir, path));
}

StreamedMeshFile::~StreamedMeshFile() = default;

void StreamedMeshFile::vertices(std::span<const Float3> positions, std::span<const Float3> normals,
                                std::span<const Float3> colours) {
  const bool wantNormals = options_.normals, wantColours = options_.colours;
  if ((wantNormals && normals.size() != positions.size()) || (wantColours && colours.size() != positions.size()))
    throw std::invalid_argument("streamed mesh file: a vertex run lacks the normals or colours the file stores");
  vertices_ += positions.size();
  const std::string& f = options_.format;
  if (f == "stl") return;  // STL stores triangle corners only
  text_.clear();
  if (f == "ply" && !options_.asciiPly) {
    encodeBinaryPlyVertices(text_, positions, normals, colours, wantNormals, wantColours);
    sections_[0]->append(text_);
    return;
  }
  if (f == "ply") {  // ascii
    for (std::size_t i = 0; i < positions.size(); ++i) {
      float values[6];
      int n = 0;
      values[n++] = positions[i].x, values[n++] = positions[i].y, values[n++] = positions[i].z;
      if (wantNormals) values[n++] = normals[i].x, values[n++] = normals[i].y, values[n++] = normals[i].z;
      for (int k = 0; k < n; ++k) {
        if (k) text_ += ' ';
        detail::appendFloat(text_, values[k]);
      }
      if (wantColours)
        for (std::uint8_t b : {colourByte(colours[i].x), colourByte(colours[i].y), colourByte(colours[i].z)}) {
          text_ += ' ';
          detail::appendUint(text_, b);
        }
      text_ += '\n';
    }
    sections_[0]->append(text_);
    return;
  }
  // OBJ: "v x y z [r g b]" lines, then (another section) "vn" lines.
  for (std::size_t i = 0; i < positions.size(); ++i) {
    text_ += 'v';
    appendTriple(text_, positions[i]);
    if (wantColours) appendTriple(text_, colours[i]);
    text_ += '\n';
  }
  sections_[0]->append(text_);
  if (wantNormals) {
    text_.clear();
    for (const Float3& n : normals) {
      text_ += "vn";
      appendTriple(text_, n);
      text_ += '\n';
    }
    sections_[1]->append(text_);
  }
}

void StreamedMeshFile::triangles(std::span<const std::array<std::uint32_t, 3>> triangles,
                                 const VertexWindow& window) {
  triangles_ += triangles.size();
  const std::string& f = options_.format;
  text_.clear();
  if (f == "ply" && !options_.asciiPly) {
    encodeBinaryPlyTriangles(text_, triangles);
    sections_[1]->append(text_);
  } else if (f == "ply") {  // ascii
    for (const auto& t : triangles) {
      text_ += '3';
      for (std::uint32_t v : t) {
        text_ += ' ';
        detail::appendUint(text_, v);
      }
      text_ += '\n';
    }
    sections_[1]->append(text_);
  } else if (f == "obj") {
    for (const auto& t : triangles) {
      text_ += 'f';
      for (std::uint32_t v : t) {
        text_ += ' ';
        detail::appendUint(text_, std::uint64_t(v) + 1);
        if (options_.normals) {
          text_ += "//";
          detail::appendUint(text_, std::uint64_t(v) + 1);
        }
      }
      text_ += '\n';
    }
    sections_.back()->append(text_);
  } else {
    for (const auto& t : triangles) {  // stl.cpp's facet: normal from the geometry
      const Float3 &a = window[t[0]], &b = window[t[1]], &c = window[t[2]];
      const float ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
      const float vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
      float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
      if (len > 0.0f) nx /= len, ny /= len, nz /= len;
      for (float v : {nx, ny, nz, a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z}) detail::appendRaw(text_, v);
      detail::appendRaw(text_, std::uint16_t(0));
    }
    sections_[0]->append(text_);
  }
}

std::vector<std::uint64_t> StreamedMeshFile::sectionBytes() const {
  std::vector<std::uint64_t> bytes;
  for (const auto& s : sections_) bytes.push_back(s->bytes());
  return bytes;
}

void StreamedMeshFile::writeAt(int fd, const std::string& bytes, std::uint64_t offset, const std::string& what) {
  writeAllAt(fd, bytes.data(), bytes.size(), offset, what);
}

void StreamedMeshFile::append(int in, int out, std::uint64_t length, const std::string& what) {
  copyAll(in, out, length, what);
}

void StreamedMeshFile::place(int fd, const std::vector<Placement>& placements) {
  for (auto& s : sections_) s->flush();
  const std::uint64_t kPiece = std::max<std::uint64_t>(1, options_.copyPieceBytes);
  std::vector<CopyPiece> pieces;
  for (const Placement& p : placements) {
    if (p.section < 0 || std::size_t(p.section) >= sections_.size() || p.from + p.length > sections_[std::size_t(p.section)]->size())
      throw std::out_of_range("streamed mesh file: a placement outside the spooled sections");
    for (std::uint64_t done = 0; done < p.length; done += kPiece)
      pieces.push_back({sections_[std::size_t(p.section)]->fd(), p.from + done, p.to + done, std::min(kPiece, p.length - done)});
  }
  copyPieces(pieces, fd, path_);
}

std::string StreamedMeshFile::headerFor(std::uint64_t vertices, std::uint64_t triangles) const {
  const std::string& f = options_.format;
  std::string out;
  if (f == "ply") {  // ply.cpp's header
    out += "ply\nformat ";
    out += options_.asciiPly ? "ascii" : "binary_little_endian";
    out += " 1.0\ncomment written by blobvk\nelement vertex ";
    detail::appendUint(out, vertices);
    out += "\nproperty float x\nproperty float y\nproperty float z\n";
    // An empty mesh in memory has no normal or colour arrays, so ply.cpp declares none: the
    // same bytes here (with no vertex, the properties would describe nothing anyway).
    if (options_.normals && vertices > 0) out += "property float nx\nproperty float ny\nproperty float nz\n";
    if (options_.colours && vertices > 0) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    out += "element face ";
    detail::appendUint(out, triangles);
    out += "\nproperty list uchar int vertex_indices\nend_header\n";
  } else if (f == "obj") {
    out = "# written by blobvk\n";
  } else {
    if (triangles > std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("writeStl: too many triangles for STL");
    char text[80] = {};
    std::snprintf(text, sizeof text, "binary STL written by blobvk");
    out.append(text, sizeof text);
    detail::appendRaw(out, std::uint32_t(triangles));
  }
  return out;
}

std::uint64_t StreamedMeshFile::finish() {
  if (finished_) throw std::logic_error("streamed mesh file: finish() called twice");
  finished_ = true;
  for (auto& s : sections_) s->flush();
  const std::string head = header();
  std::uint64_t total = head.size();
  for (auto& s : sections_) total += s->size();
  if (path_ == "-") {
    writeAll(STDOUT_FILENO, head.data(), head.size(), "standard output");
    for (auto& s : sections_) copyAll(s->fd(), STDOUT_FILENO, s->size(), "standard output");
    return total;
  }
  const OutputPlace place = resolveOutputPlace(path_);
  // Into the file itself: a device or FIFO (never renamed over), or a file whose folder takes no
  // temporary or whose place takes no rename (a file bind-mounted into a container).
  const auto writeInPlace = [&] {
    const int out = ::open(place.path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (out < 0) throw std::runtime_error(path_ + ": cannot write: " + reason());
    try {
      writeAll(out, head.data(), head.size(), path_);
      for (auto& s : sections_) copyAll(s->fd(), out, s->size(), path_);
    } catch (...) {
      ::close(out);
      throw;
    }
    if (::close(out) != 0) throw std::runtime_error(path_ + ": write error: " + reason());
  };
  if (!place.replaceByRename) {
    writeInPlace();
    return total;
  }
  std::string name = directoryOf(place.path) + "/.blobvk-out-XXXXXX";
  int fd = ::mkstemp(name.data());
  if (fd < 0) {
    if (!renameImpossible(errno))
      throw std::runtime_error(directoryOf(place.path) + ": cannot create a temporary file: " + reason());
    writeInPlace();
    return total;
  }
  try {
    writeAll(fd, head.data(), head.size(), path_);
    // Each section in pieces, copied to its place in the file.
    const std::uint64_t kPiece = std::max<std::uint64_t>(1, options_.copyPieceBytes);
    std::vector<CopyPiece> pieces;
    std::uint64_t at = head.size();
    for (auto& s : sections_) {
      for (std::uint64_t from = 0; from < s->size(); from += kPiece)
        pieces.push_back({s->fd(), from, at + from, std::min(kPiece, s->size() - from)});
      at += s->size();
    }
    copyPieces(pieces, fd, path_);
    setReplacementMode(fd, place.path);
    const int closed = ::close(fd);
    fd = -1;
    if (closed != 0) throw std::runtime_error(path_ + ": write error: " + reason());
    if (::rename(name.c_str(), place.path.c_str()) != 0) {
      const int err = errno;
      if (!renameImpossible(err)) throw std::runtime_error(path_ + ": cannot write: " + std::strerror(err));
      ::unlink(name.c_str());
      writeInPlace();  // the spools are still there
    }
  } catch (...) {
    if (fd >= 0) ::close(fd);
    ::unlink(name.c_str());
    throw;
  }
  return total;
}

}  // namespace blobvk::mesh
