// STL writer (binary) and reader (binary or ascii). STL stores unshared triangle corners, so the
// reader welds corners with bit-identical positions back into indexed vertices.
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/io_detail.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <vector>

namespace blobvk::mesh {

std::string encodeStl(const TriMesh& mesh) {
  detail::validateForWrite(mesh, "writeStl");
  if (mesh.triangles.size() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("writeStl: too many triangles for STL");
  std::string out;
  out.reserve(84 + 50 * mesh.triangles.size());
  // 80-byte header; it must not begin with "solid", which would read as ascii STL.
  char header[80] = {};
  std::snprintf(header, sizeof header, "binary STL written by blobvk");
  out.append(header, sizeof header);
  detail::appendRaw(out, std::uint32_t(mesh.triangles.size()));
  for (const auto& t : mesh.triangles) {
    const Float3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const float ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
    const float vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (len > 0.0f) nx /= len, ny /= len, nz /= len;
    for (float f : {nx, ny, nz, a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z}) detail::appendRaw(out, f);
    detail::appendRaw(out, std::uint16_t(0));
  }
  return out;
}

void writeStl(const TriMesh& mesh, const std::string& path) { detail::writeFileBytes(path, encodeStl(mesh)); }

namespace {

struct PositionKey {
  std::uint32_t x, y, z;
  bool operator==(const PositionKey&) const = default;
};
struct PositionHash {
  std::size_t operator()(const PositionKey& k) const {
    std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) + k.y * 0xBF58476D1CE4E5B9ull;
    h ^= (h >> 31) + k.z * 0x94D049BB133111EBull;
    return std::size_t(h ^ (h >> 32));
  }
};

class Welder {
 public:
  explicit Welder(TriMesh& mesh) : mesh_(mesh) {}
  std::uint32_t add(const Float3& p) {
    // +0 and -0 weld together; NaNs weld by bit pattern (hostile input, still no crash).
    const Float3 q{p.x == 0.0f ? 0.0f : p.x, p.y == 0.0f ? 0.0f : p.y, p.z == 0.0f ? 0.0f : p.z};
    PositionKey key;
    std::memcpy(&key.x, &q.x, 4);
    std::memcpy(&key.y, &q.y, 4);
    std::memcpy(&key.z, &q.z, 4);
    const auto [it, inserted] = index_.try_emplace(key, std::uint32_t(mesh_.positions.size()));
    if (inserted) mesh_.positions.push_back(p);
    return it->second;
  }

 private:
  TriMesh& mesh_;
  std::unordered_map<PositionKey, std::uint32_t, PositionHash> index_;
};

TriMesh readAsciiStl(const std::string& path, std::string_view text) {
  TriMesh mesh;
  Welder welder(mesh);
  std::array<std::uint32_t, 3> corners{};
  int cornerCount = 0;
  std::size_t pos = 0, facets = 0;
  const auto isSpace = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  const auto next = [&]() -> std::string_view {
    while (pos < text.size() && isSpace(text[pos])) ++pos;
    const std::size_t start = pos;
    while (pos < text.size() && !isSpace(text[pos])) ++pos;
    return text.substr(start, pos - start);
  };
  for (std::string_view word = next(); !word.empty(); word = next()) {
    if (word == "facet") {
      if (cornerCount != 0) detail::fail(path, "ascii STL facet " + std::to_string(facets) + " is incomplete");
      ++facets;
    } else if (word == "vertex") {
      float v[3];
      for (float& f : v)
        if (!detail::parseFloat(next(), f))
          detail::fail(path, "ascii STL facet " + std::to_string(facets) + " has a malformed vertex");
      if (cornerCount == 3) detail::fail(path, "ascii STL facet " + std::to_string(facets) + " has more than 3 vertices");
      corners[std::size_t(cornerCount++)] = welder.add({v[0], v[1], v[2]});
    } else if (word == "endfacet") {
      if (cornerCount != 3) detail::fail(path, "ascii STL facet " + std::to_string(facets) + " does not have 3 vertices");
      mesh.triangles.push_back(corners);
      cornerCount = 0;
    }
  }
  if (cornerCount != 0) detail::fail(path, "ascii STL ends inside a facet");
  if (facets == 0 && text.find("endsolid") == std::string_view::npos)
    detail::fail(path, "not an STL file (no facets, no endsolid)");
  return mesh;
}

}  // namespace

TriMesh readStl(const std::string& path) {
  const std::string bytes = detail::readFileBytes(path);
  if (bytes.size() >= 84) {
    std::uint32_t count = 0;
    std::memcpy(&count, bytes.data() + 80, 4);
    if (bytes.size() == 84 + 50ull * count) {
      TriMesh mesh;
      Welder welder(mesh);
      mesh.triangles.reserve(count);
      for (std::uint32_t t = 0; t < count; ++t) {
        const char* record = bytes.data() + 84 + 50ull * t + 12;  // skip the facet normal
        std::array<std::uint32_t, 3> tri{};
        for (int k = 0; k < 3; ++k) {
          float p[3];
          std::memcpy(p, record + 12 * k, 12);
          tri[std::size_t(k)] = welder.add({p[0], p[1], p[2]});
        }
        mesh.triangles.push_back(tri);
      }
      return mesh;
    }
  }
  if (bytes.compare(0, 5, "solid") == 0) return readAsciiStl(path, bytes);
  detail::fail(path, "not an STL file: " + std::to_string(bytes.size()) +
                         " bytes match neither the binary layout (84 + 50 per triangle) nor ascii");
}

}  // namespace blobvk::mesh
