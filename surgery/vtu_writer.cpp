#include "blobvk/surgery/vtu_writer.h"

#include <charconv>
#include <fstream>
#include <stdexcept>

namespace blobvk::surgery {
namespace {

// Numbers through std::to_chars: locale-independent and exact on reading back.
template <typename T>
void put(std::ostream& out, T value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.write(buffer, result.ptr - buffer);
}

template <typename Each>
void dataArray(std::ostream& out, const char* type, const char* name, int components, std::size_t count, Each each) {
  out << "        <DataArray type=\"" << type << "\"";
  if (name) out << " Name=\"" << name << "\"";
  if (components > 1) out << " NumberOfComponents=\"" << components << "\"";
  out << " format=\"ascii\">\n";
  for (std::size_t i = 0; i < count; ++i) {
    each(i);
    out << '\n';
  }
  out << "        </DataArray>\n";
}

}  // namespace

void writeVtu(std::ostream& out, const mesh::TetMesh& m, const std::vector<std::vector<std::uint32_t>>& parts) {
  const std::size_t nodes = m.nodeCount(), tets = m.tetCount();
  if (m.restPositions.size() != nodes) throw std::invalid_argument("writeVtu: rest positions and positions differ in count");
  std::vector<std::uint32_t> partOf(tets, 0xffffffffu);
  for (std::size_t p = 0; p < parts.size(); ++p)
    for (std::uint32_t t : parts[p])
      if (t < tets) partOf[t] = std::uint32_t(p);
  auto triple = [&out](const mesh::Double3& v) {
    put(out, v.x);
    out << ' ';
    put(out, v.y);
    out << ' ';
    put(out, v.z);
  };
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
         "  <UnstructuredGrid>\n"
      << "    <Piece NumberOfPoints=\"" << nodes << "\" NumberOfCells=\"" << tets << "\">\n";
  out << "      <PointData Vectors=\"displacement\">\n";
  dataArray(out, "Float64", "displacement", 3, nodes, [&](std::size_t i) {
    const mesh::Double3 &x = m.positions[i], &r = m.restPositions[i];
    triple({x.x - r.x, x.y - r.y, x.z - r.z});
  });
  out << "      </PointData>\n      <CellData Scalars=\"region\">\n";
  dataArray(out, "UInt32", "region", 1, tets, [&](std::size_t t) { put(out, m.regions.empty() ? 0u : m.regions[t]); });
  dataArray(out, "UInt32", "part", 1, tets, [&](std::size_t t) { put(out, partOf[t]); });
  out << "      </CellData>\n      <Points>\n";
  dataArray(out, "Float64", nullptr, 3, nodes, [&](std::size_t i) { triple(m.positions[i]); });
  out << "      </Points>\n      <Cells>\n";
  dataArray(out, "Int64", "connectivity", 1, tets, [&](std::size_t t) {
    for (int k = 0; k < 4; ++k) {
      if (k) out << ' ';
      put(out, std::int64_t(m.tets[t][std::size_t(k)]));
    }
  });
  dataArray(out, "Int64", "offsets", 1, tets, [&](std::size_t t) { put(out, std::int64_t(4 * (t + 1))); });
  dataArray(out, "UInt8", "types", 1, tets, [&](std::size_t) { out << "10"; });
  out << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
}

void writeVtu(const std::string& path, const mesh::TetMesh& m, const std::vector<std::vector<std::uint32_t>>& parts) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot write");
  writeVtu(out, m, parts);
  out.flush();
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace blobvk::surgery
