// File access, number parsing and the extension dispatch shared by the mesh readers/writers.
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/io_detail.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

static_assert(std::endian::native == std::endian::little,
              "mesh binary I/O writes host bytes and assumes a little-endian host");

namespace blobvk::mesh::detail {

std::string readFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) fail(path, "read error");
  return std::move(bytes).str();
}

void writeFileBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) fail(path, std::string("cannot write: ") + std::strerror(errno));
  out.write(bytes.data(), std::streamsize(bytes.size()));
  out.close();
  if (!out) fail(path, std::string("write error: ") + std::strerror(errno));
}

void fail(const std::string& path, const std::string& problem) {
  throw std::runtime_error(path + ": " + problem);
}

void validateForWrite(const TriMesh& mesh, const char* writer) {
  const std::size_t n = mesh.positions.size();
  if (!mesh.normals.empty() && mesh.normals.size() != n)
    throw std::invalid_argument(std::string(writer) + ": " + std::to_string(mesh.normals.size()) +
                                " normals for " + std::to_string(n) + " vertices");
  if (!mesh.colours.empty() && mesh.colours.size() != n)
    throw std::invalid_argument(std::string(writer) + ": " + std::to_string(mesh.colours.size()) +
                                " colours for " + std::to_string(n) + " vertices");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t v : mesh.triangles[t])
      if (v >= n)
        throw std::invalid_argument(std::string(writer) + ": triangle " + std::to_string(t) +
                                    " uses vertex " + std::to_string(v) + " of " +
                                    std::to_string(n));
}

bool parseDouble(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);  // from_chars rejects '+'
  const auto res = std::from_chars(token.data(), token.data() + token.size(), value);
  return res.ec == std::errc() && res.ptr == token.data() + token.size() && !token.empty();
}

bool parseFloat(std::string_view token, float& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto res = std::from_chars(token.data(), token.data() + token.size(), value);
  return res.ec == std::errc() && res.ptr == token.data() + token.size() && !token.empty();
}

bool parseInt64(std::string_view token, long long& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto res = std::from_chars(token.data(), token.data() + token.size(), value);
  return res.ec == std::errc() && res.ptr == token.data() + token.size() && !token.empty();
}

std::string lowerExtension(const std::string& path) {
  const std::size_t slash = path.find_last_of("/\\");
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

std::vector<std::string_view> splitWords(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j > i) words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

}  // namespace blobvk::mesh::detail

namespace blobvk::mesh {

std::string encodeMesh(const TriMesh& mesh, const std::string& format) {
  std::string ext = format;
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == "ply" || ext == ".ply") return encodePly(mesh, true);
  if (ext == "obj" || ext == ".obj") return encodeObj(mesh);
  if (ext == "stl" || ext == ".stl") return encodeStl(mesh);
  throw std::invalid_argument("cannot encode a mesh as '" + format + "' (known: ply, obj, stl)");
}

void writeMesh(const TriMesh& mesh, const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == ".ply") return writePly(mesh, path, true);
  if (ext == ".obj") return writeObj(mesh, path);
  if (ext == ".stl") return writeStl(mesh, path);
  throw std::invalid_argument("cannot write mesh '" + path + "': unknown extension '" + ext +
                              "' (expected .ply, .obj or .stl)");
}

TriMesh readMesh(const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == ".ply") return readPly(path);
  if (ext == ".obj") return readObj(path);
  if (ext == ".stl") return readStl(path);
  throw std::invalid_argument("cannot read mesh '" + path + "': unknown extension '" + ext +
                              "' (expected .ply, .obj or .stl)");
}

}  // namespace blobvk::mesh
