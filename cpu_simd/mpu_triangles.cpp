// See mpu_triangles.h. Per row of cells, the mixed cells (case neither 0 nor 255) come from word
// operations on the four point rows around it; a cell whose far corners are all owned reads its
// vertex ids through a per-case table of offsets, a cell on the MPU's high faces names the edges
// a neighbour owns as deferred references (point and axis), resolved by the welding.
#include "blobvk/cpu_simd/mpu_triangles.h"

#include "blobvk/mesh/marching_cubes.h"

namespace blobvk::cpu::detail {
namespace {

std::uint32_t encodeDeferred(int x, int y, int z, int axis) {
  return kDeferred | std::uint32_t(x) | (std::uint32_t(y) << 7) | (std::uint32_t(z) << 14) |
         (std::uint32_t(axis) << 21);
}

}  // namespace

void mpuTriangles(const RowBits* rows, const glm::ivec3& pts, const glm::ivec3& owned,
                  const std::uint32_t* vertexId, TriangleScratch& s, MpuResult& r) {
  const std::size_t sy = std::size_t(pts.x), sz = std::size_t(pts.x) * std::size_t(pts.y);
  const auto rowBits = [&](int j, int k) { return rows[std::size_t(k) * std::size_t(pts.y) + std::size_t(j)]; };
  const auto& cases = mesh::marchingCubesCases();
  const int ncx = pts.x - 1, ncy = pts.y - 1, ncz = pts.z - 1;
  const RowBits cellMask = lowBits(ncx);
  r.triangleRowStart.resize(std::size_t(ncy) * std::size_t(ncz) + 1);
  // Per case: its triangles' corners as offsets from the cell's first point in vertexId (built
  // once per field-cache shape, which is the same for nearly every MPU).
  if (s.caseSy != sy || s.caseSz != sz) {
    s.caseSy = sy, s.caseSz = sz;
    s.caseOffsets.resize(256);
    for (std::size_t c = 0; c < 256; ++c) {
      const mesh::McCase& mc = cases[c];
      s.caseOffsets[c].corners = std::uint8_t(mc.triangleCount * 3);
      for (int v = 0; v < mc.triangleCount * 3; ++v) {
        const int e = mc.edges[std::size_t(v)];
        const std::array<int, 3> d = mesh::mcEdgeStart(e);
        s.caseOffsets[c].offset[std::size_t(v)] = std::int32_t(
            (std::size_t(d[2]) * sz + std::size_t(d[1]) * sy + std::size_t(d[0])) * 3 + std::size_t(mesh::mcEdgeAxis(e)));
      }
    }
  }
  const TriangleScratch::CaseOffsets* caseOffsets = s.caseOffsets.data();
  std::size_t nt = 0;
  for (int k = 0; k < ncz; ++k) {
    for (int j = 0; j < ncy; ++j) {
      r.triangleRowStart[std::size_t(k * ncy + j)] = std::uint32_t(nt);
      const RowBits b00 = rowBits(j, k), b10 = rowBits(j + 1, k), b01 = rowBits(j, k + 1),
                            b11 = rowBits(j + 1, k + 1);
      // Mixed cells (case neither 0 nor 255): some corner is inside and some is not.
      const RowBits any4 = b00 | b10 | b01 | b11;
      const RowBits all4 = b00 & b10 & b01 & b11;
      const RowBits mixed = (any4 | (any4 >> 1)) & ~(all4 & (all4 >> 1)) & cellMask;
      if (!mixed) continue;
      if (s.tris.size() < nt + 5 * 64) s.tris.resize(nt + 5 * 64 + s.tris.size());  // a row: <= 64 cells of <= 5
      std::array<std::uint32_t, 3>* __restrict tris = s.tris.data();
      // A cell whose far corners are owned here needs no neighbour's vertex.
      const int ownedCells = j + 1 < owned.y && k + 1 < owned.z ? owned.x - 1 : 0;
      const std::size_t rowPoint = std::size_t(k) * sz + std::size_t(j) * sy;
      forEachBit(mixed, [&](int i) {
        // Corner c at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) sets bit c.
        const unsigned config = (unsigned(b00 >> i) & 3u) | (unsigned(b10 >> i) & 3u) << 2 |
                                (unsigned(b01 >> i) & 3u) << 4 | (unsigned(b11 >> i) & 3u) << 6;
        if (i < ownedCells) {
          const std::uint32_t* cell = vertexId + (rowPoint + std::size_t(i)) * 3;
          const TriangleScratch::CaseOffsets& co = caseOffsets[config];
          for (int v = 0; v < co.corners; v += 3, ++nt)
            tris[nt] = {cell[co.offset[v]], cell[co.offset[v + 1]], cell[co.offset[v + 2]]};
          return;
        }
        const mesh::McCase& mc = cases[config];
        const int count = mc.triangleCount;
        for (int t = 0; t < count; ++t, ++nt) {
          for (int v = 0; v < 3; ++v) {
            const int e = mc.edges[std::size_t(t * 3 + v)];
            const std::array<int, 3> st3 = mesh::mcEdgeStart(e);
            const int axis = mesh::mcEdgeAxis(e);
            const int x = i + st3[0], y = j + st3[1], z = k + st3[2];
            tris[nt][std::size_t(v)] =
                x < owned.x && y < owned.y && z < owned.z
                    ? vertexId[(std::size_t(z) * sz + std::size_t(y) * sy + std::size_t(x)) * 3 + std::size_t(axis)]
                    : encodeDeferred(x, y, z, axis);
          }
        }
      });
    }
  }
  r.triangleRowStart.back() = std::uint32_t(nt);
  r.triangles.assign(s.tris.begin(), s.tris.begin() + std::ptrdiff_t(nt));
}

}  // namespace blobvk::cpu::detail
