// PLY writer and reader. The reader parses any element/property layout generically (so unknown
// elements are skipped correctly in binary files) and picks out vertex and face data by name.
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/io_detail.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

static_assert(sizeof(blobvk::mesh::Float3) == 12, "binary PLY copies positions and normals as 3 packed floats");

namespace blobvk::mesh {

// ---- writer ----------------------------------------------------------------------------------

std::string encodePly(const TriMesh& mesh, bool binary) {
  detail::validateForWrite(mesh, "writePly");
  const bool normals = !mesh.normals.empty(), colours = !mesh.colours.empty();
  std::string out;
  out += "ply\nformat ";
  out += binary ? "binary_little_endian" : "ascii";
  out += " 1.0\ncomment written by blobvk\nelement vertex ";
  detail::appendUint(out, mesh.positions.size());
  out += "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  if (colours) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "element face ";
  detail::appendUint(out, mesh.triangles.size());
  out += "\nproperty list uchar int vertex_indices\nend_header\n";

  const auto toByte = [](float c) {
    const float clamped = std::isnan(c) ? 0.0f : std::clamp(c, 0.0f, 1.0f);
    // std::lround's value (half away from zero) without its library call per channel: a float in
    // [0, 255] plus 0.5 is exact in double, and truncating a non-negative value is its floor.
    return std::uint8_t(int(double(clamped * 255.0f) + 0.5));
  };
  if (binary) {
    // One allocation and straight copies: a pushed value at a time cost ~200 ns per triangle on
    // a million-triangle mesh. The bytes are those of the per-value path (little-endian host;
    // an int32 index has the bits of the uint32 one).
    const std::size_t vertexBytes = 12 + (normals ? 12 : 0) + (colours ? 3 : 0);
    const std::size_t headerBytes = out.size();
    out.resize(headerBytes + mesh.positions.size() * vertexBytes + mesh.triangles.size() * 13);
    char* w = out.data() + headerBytes;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      std::memcpy(w, &mesh.positions[i], 12);
      w += 12;
      if (normals) {
        std::memcpy(w, &mesh.normals[i], 12);
        w += 12;
      }
      if (colours) {
        const Float3& c = mesh.colours[i];
        *w++ = char(toByte(c.x)), *w++ = char(toByte(c.y)), *w++ = char(toByte(c.z));
      }
    }
    for (const auto& t : mesh.triangles) {
      *w++ = 3;
      std::memcpy(w, t.data(), 12);
      w += 12;
    }
    return out;
  }
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    float values[6];
    int n = 0;
    const Float3& p = mesh.positions[i];
    values[n++] = p.x, values[n++] = p.y, values[n++] = p.z;
    if (normals) {
      const Float3& q = mesh.normals[i];
      values[n++] = q.x, values[n++] = q.y, values[n++] = q.z;
    }
    for (int k = 0; k < n; ++k) {
      if (binary) {
        detail::appendRaw(out, values[k]);
      } else {
        if (k) out += ' ';
        detail::appendFloat(out, values[k]);
      }
    }
    if (colours) {
      const Float3& c = mesh.colours[i];
      const std::uint8_t rgb[3] = {toByte(c.x), toByte(c.y), toByte(c.z)};
      for (std::uint8_t b : rgb) {
        if (binary) {
          detail::appendRaw(out, b);
        } else {
          out += ' ';
          detail::appendUint(out, b);
        }
      }
    }
    if (!binary) out += '\n';
  }
  for (const auto& t : mesh.triangles) {
    if (binary) {
      detail::appendRaw(out, std::uint8_t(3));
      for (std::uint32_t v : t) detail::appendRaw(out, std::int32_t(v));
    } else {
      out += '3';
      for (std::uint32_t v : t) {
        out += ' ';
        detail::appendUint(out, v);
      }
      out += '\n';
    }
  }
  return out;
}

void writePly(const TriMesh& mesh, const std::string& path, bool binary) {
  detail::writeFileBytes(path, encodePly(mesh, binary));
}

// ---- reader ----------------------------------------------------------------------------------

namespace {

enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

int scalarSize(Scalar s) {
  switch (s) {
    case Scalar::Int8: case Scalar::UInt8: return 1;
    case Scalar::Int16: case Scalar::UInt16: return 2;
    case Scalar::Int32: case Scalar::UInt32: case Scalar::Float32: return 4;
    case Scalar::Float64: return 8;
  }
  return 0;
}

bool isInteger(Scalar s) { return s != Scalar::Float32 && s != Scalar::Float64; }

bool parseScalar(std::string_view name, Scalar& s) {
  static constexpr std::pair<std::string_view, Scalar> kNames[] = {
      {"char", Scalar::Int8},     {"int8", Scalar::Int8},       {"uchar", Scalar::UInt8},
      {"uint8", Scalar::UInt8},   {"short", Scalar::Int16},     {"int16", Scalar::Int16},
      {"ushort", Scalar::UInt16}, {"uint16", Scalar::UInt16},   {"int", Scalar::Int32},
      {"int32", Scalar::Int32},   {"uint", Scalar::UInt32},     {"uint32", Scalar::UInt32},
      {"float", Scalar::Float32}, {"float32", Scalar::Float32}, {"double", Scalar::Float64},
      {"float64", Scalar::Float64}};
  for (const auto& [n, v] : kNames)
    if (n == name) {
      s = v;
      return true;
    }
  return false;
}

struct Property {
  std::string name;
  Scalar type = Scalar::Float32;
  bool isList = false;
  Scalar countType = Scalar::UInt8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

// Reads scalar values from the body, ascii or binary, never past the end.
class BodyReader {
 public:
  BodyReader(const std::string& path, std::string_view body, bool binary)
      : path_(path), body_(body), binary_(binary) {}

  std::size_t remaining() const { return body_.size() - pos_; }

  double read(Scalar type, const char* what) {
    return binary_ ? readBinary(type, what) : readAscii(type, what);
  }

 private:
  double readBinary(Scalar type, const char* what) {
    const int size = scalarSize(type);
    if (remaining() < std::size_t(size))
      detail::fail(path_, std::string("unexpected end of binary data while reading ") + what);
    const char* p = body_.data() + pos_;
    pos_ += std::size_t(size);
    switch (type) {
      case Scalar::Int8: return double(std::int8_t(*p));
      case Scalar::UInt8: return double(std::uint8_t(*p));
      case Scalar::Int16: { std::int16_t v; std::memcpy(&v, p, 2); return v; }
      case Scalar::UInt16: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
      case Scalar::Int32: { std::int32_t v; std::memcpy(&v, p, 4); return v; }
      case Scalar::UInt32: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
      case Scalar::Float32: { float v; std::memcpy(&v, p, 4); return v; }
      case Scalar::Float64: { double v; std::memcpy(&v, p, 8); return v; }
    }
    return 0.0;
  }

  double readAscii(Scalar type, const char* what) {
    const auto isSpace = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
    while (pos_ < body_.size() && isSpace(body_[pos_])) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < body_.size() && !isSpace(body_[pos_])) ++pos_;
    const std::string_view token = body_.substr(start, pos_ - start);
    if (token.empty()) detail::fail(path_, std::string("unexpected end of ascii data while reading ") + what);
    double value = 0.0;
    if (!detail::parseDouble(token, value))
      detail::fail(path_, "'" + std::string(token.substr(0, 32)) + "' is not a number (" + what + ")");
    if (isInteger(type) && value != std::floor(value))
      detail::fail(path_, "'" + std::string(token.substr(0, 32)) + "' is not an integer (" + what + ")");
    return value;
  }

  const std::string& path_;
  std::string_view body_;
  bool binary_;
  std::size_t pos_ = 0;
};

int findProperty(const Element& e, std::string_view name) {
  for (std::size_t i = 0; i < e.properties.size(); ++i)
    if (!e.properties[i].isList && e.properties[i].name == name) return int(i);
  return -1;
}

// Indices of three named scalar properties, or all -1 unless all three are present.
std::array<int, 3> findTriple(const Element& e, const char* a, const char* b, const char* c) {
  std::array<int, 3> idx = {findProperty(e, a), findProperty(e, b), findProperty(e, c)};
  if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0) return {-1, -1, -1};
  return idx;
}

std::string numberText(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

TriMesh readPly(const std::string& path) {
  const std::string bytes = detail::readFileBytes(path);
  const std::string_view all(bytes);

  if (all.substr(0, 3) != "ply") detail::fail(path, "not a PLY file (it does not start with 'ply')");
  // Header: lines up to and including "end_header".
  std::vector<Element> elements;
  bool binary = false, sawFormat = false;
  std::size_t pos = 0, lineNo = 0;
  bool ended = false;
  while (!ended) {
    if (pos >= all.size()) detail::fail(path, "PLY header has no end_header line");
    std::size_t eol = all.find('\n', pos);
    if (eol == std::string_view::npos) eol = all.size();
    const std::string_view line = all.substr(pos, eol - pos);
    pos = std::min(all.size(), eol + 1);
    ++lineNo;
    const auto words = detail::splitWords(line);
    const std::string where = "PLY header line " + std::to_string(lineNo) + ": ";
    if (lineNo == 1) {
      if (words.size() != 1 || words[0] != "ply") detail::fail(path, "not a PLY file (first line is not 'ply')");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "format") {
      if (words.size() != 3) detail::fail(path, where + "malformed format line");
      if (words[1] == "ascii") binary = false;
      else if (words[1] == "binary_little_endian") binary = true;
      else detail::fail(path, where + "unsupported format '" + std::string(words[1]) + "'");
      sawFormat = true;
    } else if (words[0] == "element") {
      long long count = -1;
      if (words.size() != 3 || !detail::parseInt64(words[2], count) || count < 0)
        detail::fail(path, where + "malformed element line");
      elements.push_back({std::string(words[1]), std::uint64_t(count), {}});
    } else if (words[0] == "property") {
      if (elements.empty()) detail::fail(path, where + "property before any element");
      Property p;
      if (words.size() == 5 && words[1] == "list") {
        p.isList = true;
        if (!parseScalar(words[2], p.countType) || !parseScalar(words[3], p.type))
          detail::fail(path, where + "unknown list types");
        if (!isInteger(p.countType)) detail::fail(path, where + "list count type must be an integer");
        p.name = words[4];
      } else if (words.size() == 3) {
        if (!parseScalar(words[1], p.type))
          detail::fail(path, where + "unknown property type '" + std::string(words[1]) + "'");
        p.name = words[2];
      } else {
        detail::fail(path, where + "malformed property line");
      }
      elements.back().properties.push_back(p);
    } else if (words[0] == "end_header") {
      ended = true;
    } else {
      detail::fail(path, where + "unknown keyword '" + std::string(words[0].substr(0, 32)) + "'");
    }
  }
  if (!sawFormat) detail::fail(path, "PLY header has no format line");

  const Element* vertexElement = nullptr;
  for (const Element& e : elements)
    if (e.name == "vertex") vertexElement = &e;
  if (!vertexElement) detail::fail(path, "PLY has no vertex element");
  const std::array<int, 3> xyz = findTriple(*vertexElement, "x", "y", "z");
  if (xyz[0] < 0) detail::fail(path, "PLY vertex element lacks x, y or z");

  TriMesh mesh;
  BodyReader body(path, all.substr(pos), binary);
  std::vector<double> values;
  for (const Element& e : elements) {
    // Hostile counts: each entry takes at least this many bytes, so the count is bounded by the
    // bytes left (checked before anything is allocated).
    std::size_t minBytes = 0;
    for (const Property& p : e.properties)
      minBytes += binary ? std::size_t(scalarSize(p.isList ? p.countType : p.type)) : 2;
    // (An ascii file may omit the final newline, hence the + 1.)
    const std::size_t available = body.remaining() + (binary ? 0 : 1);
    if (minBytes > 0 && e.count > available / minBytes)
      detail::fail(path, "element '" + e.name + "' declares " + std::to_string(e.count) +
                             " entries but only " + std::to_string(body.remaining()) +
                             " bytes of data follow");
    if (e.properties.empty()) continue;  // no bytes to read, whatever the count says

    const bool isVertex = &e == vertexElement;
    const bool isFace = e.name == "face";
    int faceList = -1;
    if (isFace)
      for (std::size_t i = 0; i < e.properties.size(); ++i)
        if (e.properties[i].isList &&
            (e.properties[i].name == "vertex_indices" || e.properties[i].name == "vertex_index"))
          faceList = int(i);
    if (isFace && faceList < 0 && e.count > 0)
      detail::fail(path, "PLY face element has no vertex_indices list");
    std::array<int, 3> nrm{-1, -1, -1}, rgb{-1, -1, -1};
    float colourScale = 1.0f;
    if (isVertex) {
      nrm = findTriple(e, "nx", "ny", "nz");
      rgb = findTriple(e, "red", "green", "blue");
      if (rgb[0] < 0) rgb = findTriple(e, "diffuse_red", "diffuse_green", "diffuse_blue");
      if (rgb[0] >= 0 && isInteger(e.properties[std::size_t(rgb[0])].type)) colourScale = 1.0f / 255.0f;
      mesh.positions.reserve(e.count);
      if (nrm[0] >= 0) mesh.normals.reserve(e.count);
      if (rgb[0] >= 0) mesh.colours.reserve(e.count);
    }
    values.resize(e.properties.size());
    std::vector<std::uint32_t> polygon;
    for (std::uint64_t item = 0; item < e.count; ++item) {
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
        const Property& p = e.properties[pi];
        if (!p.isList) {
          values[pi] = body.read(p.type, p.name.c_str());
          continue;
        }
        const double count = body.read(p.countType, "list count");
        if (count < 0) detail::fail(path, "negative list length in element '" + e.name + "'");
        // Each list value takes at least one byte (binary) or two (ascii): bound the length.
        if (count > double(body.remaining())) detail::fail(path, "list length " + numberText(count) + " runs past the end of the file");
        const bool keep = isFace && int(pi) == faceList;
        if (keep) {
          if (count < 3) detail::fail(path, "face " + std::to_string(item) + " has fewer than 3 vertices");
          if (!isInteger(p.type)) detail::fail(path, "face indices must be integers");
          polygon.clear();
        }
        for (std::uint64_t k = 0; k < std::uint64_t(count); ++k) {
          const double v = body.read(p.type, "list value");
          if (keep) {
            if (v < 0 || v >= 4294967295.0)
              detail::fail(path, "face " + std::to_string(item) + " has invalid vertex index " + numberText(v));
            polygon.push_back(std::uint32_t(v));
          }
        }
        if (keep)
          for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
            mesh.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
      }
      if (isVertex) {
        const auto f = [&](int i) {
          const double v = values[std::size_t(i)];
          if (std::abs(v) > double(std::numeric_limits<float>::max()))  // NaN passes through
            detail::fail(path, "vertex " + std::to_string(item) + " has value " + numberText(v) +
                                   " outside the float range");
          return float(v);
        };
        mesh.positions.push_back({f(xyz[0]), f(xyz[1]), f(xyz[2])});
        if (nrm[0] >= 0) mesh.normals.push_back({f(nrm[0]), f(nrm[1]), f(nrm[2])});
        if (rgb[0] >= 0)
          mesh.colours.push_back({f(rgb[0]) * colourScale, f(rgb[1]) * colourScale, f(rgb[2]) * colourScale});
      }
    }
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t v : mesh.triangles[t])
      if (v >= mesh.positions.size())
        detail::fail(path, "triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                               " but there are only " + std::to_string(mesh.positions.size()) + " vertices");
  return mesh;
}

}  // namespace blobvk::mesh
