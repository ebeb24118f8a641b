#include "blobvk/vk/extract/host_row_passes.h"

#include "blobvk/vk/extract/case_table.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cstddef>

namespace blobvk::vk {
namespace {

// Set bits of a row mask (at most 17): SWAR, where std::popcount is a libgcc call without -mpopcnt.
inline std::uint32_t bitCount(std::uint32_t v) {
  v = v - ((v >> 1) & 0x55555555u);
  v = (v & 0x33333333u) + ((v >> 2) & 0x33333333u);
  return (((v + (v >> 4)) & 0x0f0f0f0fu) * 0x01010101u) >> 24;
}
inline std::uint32_t lowestBit(std::uint32_t v) { return std::uint32_t(std::countr_zero(v)); }  // v != 0

// One brick of the batch, its rows walked as the kernels walk them (brick_layout.glsl: the
// same functions, the same uint32 arithmetic).
struct BrickRows {
  const HostRowLayout& layout;
  std::uint32_t a, B, R;
  const std::uint32_t* seg;  // x packed coordinates, y / z first row of points / cells, w counts
  std::array<std::uint32_t, 3> b, g0;  // the brick's coordinates, its first cell
  const std::uint32_t* rows;  // the brick's masks: row (ly, lz) at lz * R + ly
  // Per brick, the same for each of its rows: the points x < xEnd with a +x edge in the grid,
  // and those the brick owns (x < B, and x = B on the grid's last point along x).
  std::uint32_t xEndMask, ownedMask;

  BrickRows(const HostRowLayout& l, std::uint32_t brick)
      : layout(l), a(brick), B(1u << l.log2B), R((1u << l.log2B) + 1u), seg(l.segments + 4ull * brick),
        rows(l.masks + std::size_t(brick) * R * R) {
    // unpackBrick: each axis in the bits its brick count needs (BrickGrid::bitsX, bitsY).
    const std::uint32_t bx = std::uint32_t(std::bit_width(l.bricks[0] - 1u)), by = std::uint32_t(std::bit_width(l.bricks[1] - 1u));
    const std::uint32_t p = seg[0];
    b = {p & ((1u << bx) - 1u), (p >> bx) & ((1u << by) - 1u), p >> (bx + by)};
    g0 = {b[0] << l.log2B, b[1] << l.log2B, b[2] << l.log2B};
    const std::uint32_t cellsX = l.cells[0];
    xEndMask = (1u << std::min(cellsX - g0[0], B)) - 1u;
    ownedMask = g0[0] + B == cellsX ? (2u << B) - 1u : (1u << std::min(cellsX - g0[0] + 1u, B)) - 1u;
  }
  std::uint32_t segmentOf(std::uint32_t base, std::uint32_t count, std::uint32_t ly, std::uint32_t lz) const {
    return base + lz * count * (seg[3] & 0x1fffffu) + ly * (seg[3] >> 21);
  }
  // The step's four masks (MaskColumn): rows (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1), the
  // row itself past the brick.
  struct Masks {
    std::uint32_t m, my, mz, myz;
  };
  Masks masksAt(std::uint32_t ly, std::uint32_t lz) const {
    const std::uint32_t dy = ly + 1u < R ? 1u : 0u, dz = lz + 1u < R ? R : 0u;
    const std::uint32_t* r = rows + lz * R + ly;
    return {r[0], r[dy], r[dz], r[dz + dy]};
  }
  // ownedRowEdges: the row's crossing +x, +y, +z edges that it owns.
  std::array<std::uint32_t, 3> ownedEdges(const Masks& c, std::uint32_t ly, std::uint32_t lz) const {
    const auto& cells = layout.cells;
    const std::uint32_t gy = g0[1] + ly, gz = g0[2] + lz;
    const bool ownsRow = (ly < B || gy == cells[1]) && (lz < B || gz == cells[2]) && gy <= cells[1] && gz <= cells[2];
    if (!ownsRow) return {0u, 0u, 0u};
    return {(c.m ^ (c.m >> 1)) & xEndMask, gy < cells[1] ? (c.m ^ c.my) & ownedMask : 0u,
            gz < cells[2] ? (c.m ^ c.mz) & ownedMask : 0u};
  }
  // Whether row (ly, lz) of cells lies in the grid (the triangle passes' rows).
  bool cellRowInGrid(std::uint32_t ly, std::uint32_t lz) const {
    return g0[1] + ly < layout.cells[1] && g0[2] + lz < layout.cells[2];
  }
  // mixedCells, within the grid along x.
  std::uint32_t mixedCells(const Masks& c) const {
    const std::uint32_t all4 = c.m & c.my & c.mz & c.myz, any4 = c.m | c.my | c.mz | c.myz;
    return ~((all4 & (all4 >> 1)) | ~(any4 | (any4 >> 1))) & xEndMask;
  }
  static std::uint32_t cellConfig(const Masks& c, std::uint32_t x) {
    return ((c.m >> x) & 3u) | (((c.my >> x) & 3u) << 2) | (((c.mz >> x) & 3u) << 4) | (((c.myz >> x) & 3u) << 6);
  }
};

template <typename Body>
void forEachBrick(std::uint32_t bricks, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, bricks, 8), [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t a = r.begin(); a < r.end(); ++a) body(a);
  });
}

}  // namespace

void countRowsOnHost(const HostRowLayout& layout, std::uint32_t* vertexCounts, std::uint32_t* triangleCounts) {
  const std::uint32_t* cases = caseTableUniform().data();
  forEachBrick(layout.loaded, [&](std::uint32_t a) {
    const BrickRows brick(layout, a);
    for (std::uint32_t lz = 0; lz < brick.R; ++lz) {
      for (std::uint32_t ly = 0; ly < brick.R; ++ly) {
        const BrickRows::Masks c = brick.masksAt(ly, lz);
        const auto e = brick.ownedEdges(c, ly, lz);
        vertexCounts[brick.segmentOf(brick.seg[1], brick.R, ly, lz)] = bitCount(e[0]) + bitCount(e[1]) + bitCount(e[2]);
        if (ly >= brick.B || lz >= brick.B) continue;
        std::uint32_t triangles = 0;
        if (brick.cellRowInGrid(ly, lz)) {
          for (std::uint32_t cells = brick.mixedCells(c); cells != 0u; cells &= cells - 1u)
            triangles += cases[4u * BrickRows::cellConfig(c, lowestBit(cells))];
        }
        triangleCounts[brick.segmentOf(brick.seg[2], brick.B, ly, lz)] = triangles;
      }
    }
  });
}

void writeSourcesOnHost(const HostRowLayout& layout, const std::uint32_t* vertexSegments,
                        const std::uint32_t* triangleSegments, std::uint32_t* pointWords, std::uint32_t* vertexSources,
                        std::uint32_t* triangleSources) {
  const std::uint32_t* cases = caseTableUniform().data();
  forEachBrick(layout.loaded, [&](std::uint32_t a) {
    const BrickRows brick(layout, a);
    const std::uint32_t B = brick.B, R = brick.R;
    // The next layer's bricks (a >= ownActive) get their point words alone: this batch's
    // triangles of its last layer use the vertices on their lower faces.
    const bool own = a < layout.ownActive;
    const std::array<std::uint32_t, 3>& b = brick.b;
    const std::uint32_t faces = (b[0] + 1u < layout.bricks[0] ? 1u : 0u) | (b[1] + 1u < layout.bricks[1] ? 2u : 0u) |
                                (b[2] + 1u < layout.bricks[2] ? 4u : 0u);
    const std::size_t rowBase = std::size_t(a) * R * R;
    for (std::uint32_t lz = 0; lz < R; ++lz) {
      for (std::uint32_t ly = 0; ly < R; ++ly) {
        const BrickRows::Masks c = brick.masksAt(ly, lz);
        const std::uint32_t r = lz * R + ly;
        const auto e = brick.ownedEdges(c, ly, lz);
        std::uint32_t v = vertexSegments[brick.segmentOf(brick.seg[1], R, ly, lz)];
        // Each point with a crossing edge: its word (first vertex << 3 | its edges), then its
        // vertices in axis order.
        for (std::uint32_t pending = e[0] | e[1] | e[2]; pending != 0u; pending &= pending - 1u) {
          const std::uint32_t x = lowestBit(pending);
          std::uint32_t bits = ((e[0] >> x) & 1u) | (((e[1] >> x) & 1u) << 1) | (((e[2] >> x) & 1u) << 2);
          pointWords[(rowBase + r) * R + x] = (v << 3) | bits;
          for (; bits != 0u; bits &= bits - 1u, ++v) {
            if (!own) continue;
            vertexSources[2ull * v] = a;
            vertexSources[2ull * v + 1] = (r << 7) | (x << 2) | lowestBit(bits);
          }
        }
        if (!own || ly >= B || lz >= B || !brick.cellRowInGrid(ly, lz)) continue;
        std::uint32_t t = triangleSegments[brick.segmentOf(brick.seg[2], B, ly, lz)];
        const std::uint32_t tag = ((ly + (lz << layout.log2B)) << 15) | (faces << 23);
        for (std::uint32_t cells = brick.mixedCells(c); cells != 0u; cells &= cells - 1u) {
          const std::uint32_t cx = lowestBit(cells), config = BrickRows::cellConfig(c, cx);
          for (std::uint32_t k = 0, n = cases[4u * config]; k < n; ++k, ++t) {
            triangleSources[2ull * t] = a;
            triangleSources[2ull * t + 1] = config | (k << 8) | (cx << 11) | tag;
          }
        }
      }
    }
  });
}

}  // namespace blobvk::vk
