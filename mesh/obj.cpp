// Wavefront OBJ writer and reader (geometry only: materials and texture coordinates are ignored).
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/io_detail.h"

#include <cmath>
#include <limits>
#include <vector>

namespace blobvk::mesh {

std::string encodeObj(const TriMesh& mesh) {
  detail::validateForWrite(mesh, "writeObj");
  const bool normals = !mesh.normals.empty(), colours = !mesh.colours.empty();
  std::string out = "# written by blobvk\n";
  const auto appendTriple = [&out](const Float3& v) {
    out += ' ';
    detail::appendFloat(out, v.x);
    out += ' ';
    detail::appendFloat(out, v.y);
    out += ' ';
    detail::appendFloat(out, v.z);
  };
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    out += 'v';
    appendTriple(mesh.positions[i]);
    if (colours) appendTriple(mesh.colours[i]);  // the common "v x y z r g b" extension
    out += '\n';
  }
  if (normals)
    for (const Float3& n : mesh.normals) {
      out += "vn";
      appendTriple(n);
      out += '\n';
    }
  for (const auto& t : mesh.triangles) {
    out += 'f';
    for (std::uint32_t v : t) {
      out += ' ';
      detail::appendUint(out, std::uint64_t(v) + 1);
      if (normals) {
        out += "//";
        detail::appendUint(out, std::uint64_t(v) + 1);
      }
    }
    out += '\n';
  }
  return out;
}

void writeObj(const TriMesh& mesh, const std::string& path) { detail::writeFileBytes(path, encodeObj(mesh)); }

namespace {

// Resolves a 1-based (or negative, relative) OBJ index against `count` items; -1 when invalid.
long long resolveIndex(std::string_view token, std::size_t count) {
  long long i = 0;
  if (!detail::parseInt64(token, i) || i == 0) return -1;
  if (i < 0) i += (long long)count;
  else i -= 1;
  return i >= 0 && i < (long long)count ? i : -1;
}

}  // namespace

TriMesh readObj(const std::string& path) {
  const std::string bytes = detail::readFileBytes(path);
  const std::string_view all(bytes);
  TriMesh mesh;
  std::vector<Float3> normals;
  bool normalsPairOneToOne = true;       // every corner's vn index equals its v index
  bool anyCornerNormal = false;
  std::vector<std::uint32_t> polygon;
  std::size_t pos = 0, lineNo = 0;
  while (pos < all.size()) {
    std::size_t eol = all.find('\n', pos);
    if (eol == std::string_view::npos) eol = all.size();
    const std::string_view line = all.substr(pos, eol - pos);
    pos = eol + 1;
    ++lineNo;
    const auto words = detail::splitWords(line);
    if (words.empty() || words[0].front() == '#') continue;
    const std::string where = "OBJ line " + std::to_string(lineNo) + ": ";
    const auto readFloats = [&](std::size_t first, std::size_t n, float* out) {
      for (std::size_t k = 0; k < n; ++k)
        if (!detail::parseFloat(words[first + k], out[k]))
          detail::fail(path, where + "'" + std::string(words[first + k].substr(0, 32)) +
                                 "' is not a number");
    };
    if (words[0] == "v") {
      // v x y z [w] or v x y z r g b [a]
      if (words.size() != 4 && words.size() != 5 && words.size() != 7 && words.size() != 8)
        detail::fail(path, where + "a vertex needs 3 coordinates (and optionally w or r g b)");
      float v[6];
      readFloats(1, words.size() >= 7 ? 6 : 3, v);
      mesh.positions.push_back({v[0], v[1], v[2]});
      if (words.size() >= 7) {
        if (mesh.colours.size() + 1 != mesh.positions.size())
          detail::fail(path, where + "some vertices have a colour and some do not");
        mesh.colours.push_back({v[3], v[4], v[5]});
      } else if (!mesh.colours.empty()) {
        detail::fail(path, where + "some vertices have a colour and some do not");
      }
    } else if (words[0] == "vn") {
      if (words.size() != 4) detail::fail(path, where + "a normal needs 3 components");
      float n[3];
      readFloats(1, 3, n);
      normals.push_back({n[0], n[1], n[2]});
    } else if (words[0] == "f") {
      if (words.size() < 4) detail::fail(path, where + "a face needs at least 3 vertices");
      polygon.clear();
      for (std::size_t k = 1; k < words.size(); ++k) {
        const std::string_view corner = words[k];
        const std::size_t slash = corner.find('/');
        const long long v = resolveIndex(corner.substr(0, slash), mesh.positions.size());
        if (v < 0)
          detail::fail(path, where + "face vertex '" + std::string(corner.substr(0, 32)) +
                                 "' does not name one of the " +
                                 std::to_string(mesh.positions.size()) + " vertices so far");
        polygon.push_back(std::uint32_t(v));
        const std::size_t slash2 = slash == std::string_view::npos ? slash : corner.find('/', slash + 1);
        if (slash2 != std::string_view::npos) {
          anyCornerNormal = true;
          const long long n = resolveIndex(corner.substr(slash2 + 1), normals.size());
          if (n < 0) detail::fail(path, where + "face normal index in '" + std::string(corner.substr(0, 32)) + "' is invalid");
          if (n != v) normalsPairOneToOne = false;
        } else {
          normalsPairOneToOne = false;
        }
      }
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
        mesh.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
    }
    // Other statements (vt, o, g, s, usemtl, mtllib, l, ...) do not affect the mesh.
  }
  // Per-corner normals only become per-vertex normals when they pair one to one.
  if (anyCornerNormal && normalsPairOneToOne && normals.size() == mesh.positions.size())
    mesh.normals.assign(normals.begin(), normals.end());
  return mesh;
}

}  // namespace blobvk::mesh
