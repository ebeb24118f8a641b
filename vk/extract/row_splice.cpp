// spliceRows (see row_splice.h).
//
// The splice is planned as a list of segments, one per row of the box in mesh order: the old
// elements [oldFrom, oldTo) it replaces and its new count. Between segments lie runs of kept
// elements, each moved by the change in size of the segments before it (deltaAfter). The runs
// move in place: those moving left front to back, then those moving right back to front. A run's
// destination never covers a run not yet moved: the new layout keeps the runs' order, so a run
// moving left lands at or after where the run before it ends in the new layout, which is at or
// after that run's old end when it moves right (it waits), and already holds it when it moves
// left (it went first); the mirror argument holds for right-moving runs taken from the back.
// The segments' new bytes are written last, into the gaps the runs leave.
#include "blobvk/vk/extract/row_splice.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace blobvk::vk {
namespace {

struct Segment {
  std::uint64_t oldFrom = 0, oldTo = 0;  // the kept mesh's elements it replaces
  std::uint64_t pieceFrom = 0, count = 0;  // its new elements in the piece
};

struct Plan {
  std::vector<Segment> segments;
  std::vector<std::uint64_t> oldFroms;  // segments[i].oldFrom, for binary searches
  std::vector<std::uint64_t> newFrom;   // where segment i starts in the new layout
  std::vector<std::int64_t> deltaAfter;  // the shift of the kept run after segment i
  std::uint64_t oldSize = 0, newSize = 0;
};

Plan makePlan(std::vector<Segment> segments, std::uint64_t oldSize) {
  Plan p;
  p.oldSize = oldSize;
  std::int64_t delta = 0;
  for (const Segment& s : segments) {
    p.oldFroms.push_back(s.oldFrom);
    p.newFrom.push_back(std::uint64_t(std::int64_t(s.oldFrom) + delta));
    delta += std::int64_t(s.count) - std::int64_t(s.oldTo - s.oldFrom);
    p.deltaAfter.push_back(delta);
  }
  p.newSize = std::uint64_t(std::int64_t(oldSize) + delta);
  p.segments = std::move(segments);
  return p;
}

// Moves the kept runs of `v` and writes the segments from `piece`; returns the elements moved.
template <class T, class A>
std::uint64_t applyPlan(const Plan& p, std::vector<T, A>& v, const T* piece) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::size_t n = p.segments.size();
  const auto runFrom = [&](std::size_t i) { return p.segments[i].oldTo; };
  const auto runTo = [&](std::size_t i) { return i + 1 < n ? p.segments[i + 1].oldFrom : p.oldSize; };
  std::uint64_t moved = 0;
  if (p.newSize > p.oldSize) v.resize(p.newSize);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t from = runFrom(i), count = runTo(i) - from;
    if (p.deltaAfter[i] < 0 && count) {
      std::memmove(v.data() + (std::int64_t(from) + p.deltaAfter[i]), v.data() + from, count * sizeof(T));
      moved += count;
    }
  }
  for (std::size_t i = n; i-- > 0;) {
    const std::uint64_t from = runFrom(i), count = runTo(i) - from;
    if (p.deltaAfter[i] > 0 && count) {
      std::memmove(v.data() + (std::int64_t(from) + p.deltaAfter[i]), v.data() + from, count * sizeof(T));
      moved += count;
    }
  }
  if (p.newSize < p.oldSize) v.resize(p.newSize);
  for (std::size_t i = 0; i < n; ++i) {
    const Segment& s = p.segments[i];
    if (s.count) std::memcpy(v.data() + p.newFrom[i], piece + s.pieceFrom, s.count * sizeof(T));
  }
  return moved;
}

struct Dims {
  std::uint64_t nx, ny;  // points per axis
  std::uint64_t cx, cy;  // cells per axis
  std::uint64_t key(std::uint64_t x, std::uint64_t y, std::uint64_t z) const { return ((z * ny + y) * nx + x) * 3; }
  std::uint64_t cell(std::uint64_t x, std::uint64_t y, std::uint64_t z) const { return (z * cy + y) * cx + x; }
  // A triangle's cell from its corners' keys: the least point of its corners per axis, as a
  // marching-cubes triangle never lies in one upper face of its cell (tests/vk checks the table).
  std::uint64_t cellOf(std::uint64_t k0, std::uint64_t k1, std::uint64_t k2) const {
    std::uint64_t x = ~0ull, y = ~0ull, z = ~0ull;
    for (std::uint64_t k : {k0, k1, k2}) {
      const std::uint64_t p = k / 3, q = p / nx;
      x = std::min(x, p - q * nx);
      y = std::min(y, q % ny);
      z = std::min(z, q / ny);
    }
    return cell(x, y, z);
  }
};

[[noreturn]] void broken(const std::string& what) {
  throw std::logic_error("incremental extraction: " + what);
}

}  // namespace

void spliceRows(mesh::TriMesh& m, const std::array<std::uint32_t, 3>& cells, const RowBox& box,
                const mesh::TriMesh& piece, const std::vector<std::uint64_t>& cornerKeys, RowSpliceStats* stats) {
  RowSpliceStats local;
  RowSpliceStats& st = stats ? *stats : local;
  st = RowSpliceStats{};
  const Dims d{std::uint64_t(cells[0]) + 1, std::uint64_t(cells[1]) + 1, cells[0], cells[1]};
  const bool normals = !m.normals.empty(), colours = !m.colours.empty();
  const std::size_t pieceVertices = piece.positions.size();
  if (piece.edgeKeys.size() != pieceVertices || (normals && piece.normals.size() != pieceVertices) ||
      (colours && piece.colours.size() != pieceVertices) || cornerKeys.size() % 3) {
    broken("the re-run's vertex arrays differ in length");
  }
  const auto& keys = m.edgeKeys;
  const std::uint64_t* pk = piece.edgeKeys.data();

  // 1. Vertex rows: the keys of points [pointFirst.x, pointEnd.x) of each point row of the box.
  std::vector<Segment> vsegs;
  {
    auto old = keys.begin();
    std::uint64_t cursor = 0;
    for (std::uint64_t z = box.pointFirst[2]; z < box.pointEnd[2]; ++z)
      for (std::uint64_t y = box.pointFirst[1]; y < box.pointEnd[1]; ++y) {
        const std::uint64_t lo = d.key(box.pointFirst[0], y, z), hi = d.key(box.pointEnd[0], y, z);
        const auto oldFrom = std::lower_bound(old, keys.end(), lo);
        old = std::lower_bound(oldFrom, keys.end(), hi);
        const std::uint64_t from = std::uint64_t(std::lower_bound(pk + cursor, pk + pieceVertices, lo) - pk);
        if (from != cursor) broken("a re-run vertex lies outside the box's rows");
        cursor = std::uint64_t(std::lower_bound(pk + cursor, pk + pieceVertices, hi) - pk);
        vsegs.push_back({std::uint64_t(oldFrom - keys.begin()), std::uint64_t(old - keys.begin()), from, cursor - from});
      }
    if (cursor != pieceVertices) broken("a re-run vertex lies outside the box's rows");
  }
  if (vsegs.empty()) return;
  const Plan vp = makePlan(std::move(vsegs), keys.size());
  if (vp.newSize > 0xffffffffull) {
    throw std::length_error("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
  }

  // 2. Triangle rows: cells [cellFirst.x, cellEnd.x) of each cell row of the box.
  const std::uint64_t pieceTriangles = cornerKeys.size() / 3;
  std::vector<Segment> tsegs;
  {
    const auto& tris = m.triangles;
    const auto oldCell = [&](const std::array<std::uint32_t, 3>& t) {
      return d.cellOf(keys[t[0]], keys[t[1]], keys[t[2]]);
    };
    const auto pieceCell = [&](std::uint64_t t) {
      return d.cellOf(cornerKeys[3 * t], cornerKeys[3 * t + 1], cornerKeys[3 * t + 2]);
    };
    auto old = tris.begin();
    std::uint64_t cursor = 0;
    const auto pieceBelow = [&](std::uint64_t from, std::uint64_t bound) {  // first piece triangle at or past `bound`
      std::uint64_t lo = from, hi = pieceTriangles;
      while (lo < hi) {
        const std::uint64_t mid = lo + (hi - lo) / 2;
        if (pieceCell(mid) < bound) lo = mid + 1;
        else hi = mid;
      }
      return lo;
    };
    for (std::uint64_t z = box.cellFirst[2]; z < box.cellEnd[2]; ++z)
      for (std::uint64_t y = box.cellFirst[1]; y < box.cellEnd[1]; ++y) {
        const std::uint64_t lo = d.cell(box.cellFirst[0], y, z), hi = d.cell(box.cellEnd[0], y, z);
        const auto oldFrom = std::partition_point(old, tris.end(), [&](const auto& t) { return oldCell(t) < lo; });
        old = std::partition_point(oldFrom, tris.end(), [&](const auto& t) { return oldCell(t) < hi; });
        if (pieceBelow(cursor, lo) != cursor) broken("a re-run triangle lies outside the box's rows");
        const std::uint64_t from = cursor;
        cursor = pieceBelow(cursor, hi);
        tsegs.push_back({std::uint64_t(oldFrom - tris.begin()), std::uint64_t(old - tris.begin()), from, cursor - from});
      }
    if (cursor != pieceTriangles) broken("a re-run triangle lies outside the box's rows");
  }
  const Plan tp = makePlan(std::move(tsegs), m.triangles.size());

  // 3. The kept triangles' corners, while the old keys are still in place.
  {
    const std::uint64_t first = vp.segments.front().oldFrom, last = vp.segments.back().oldTo;
    const std::int64_t total = vp.deltaAfter.back();
    // Per task (the tail of a 2 M-triangle mesh is a few million corners): corners found by key,
    // and the kept triangles whose corners changed, by their new index.
    struct Tally {
      std::uint64_t byKey = 0, changedFrom = ~0ull, changedTo = 0;
    };
    tbb::combinable<Tally> tallies;
    const auto remap = [&](std::uint32_t& corner, Tally& tally) {
      const std::uint64_t i = corner;
      if (i < first) return;
      if (i >= last) {
        corner = std::uint32_t(std::int64_t(i) + total);
        return;
      }
      const std::size_t j = std::size_t(std::upper_bound(vp.oldFroms.begin(), vp.oldFroms.end(), i) - vp.oldFroms.begin()) - 1;
      const Segment& s = vp.segments[j];
      if (i >= s.oldTo) {
        corner = std::uint32_t(std::int64_t(i) + vp.deltaAfter[j]);
        return;
      }
      // A vertex of the box's rows, named by a triangle outside the box: the same edge still
      // crosses (the triangle's cell did not change), so the new row holds its key.
      const std::uint64_t key = keys[i];
      const std::uint64_t* at = std::lower_bound(pk + s.pieceFrom, pk + s.pieceFrom + s.count, key);
      if (at == pk + s.pieceFrom + s.count || *at != key) broken("a kept triangle names a vertex the re-run lost");
      corner = std::uint32_t(vp.newFrom[j] + std::uint64_t(at - (pk + s.pieceFrom)));
      ++tally.byKey;
    };
    const auto remapRange = [&](std::uint64_t from, std::uint64_t to, std::int64_t shift) {
      tbb::parallel_for(tbb::blocked_range<std::uint64_t>(from, to, 1 << 16),
                        [&](const tbb::blocked_range<std::uint64_t>& r) {
                          Tally& tally = tallies.local();
                          for (std::uint64_t t = r.begin(); t != r.end(); ++t) {
                            const std::array<std::uint32_t, 3> was = m.triangles[t];
                            for (std::uint32_t& c : m.triangles[t]) remap(c, tally);
                            if (m.triangles[t] != was) {
                              const std::uint64_t now = std::uint64_t(std::int64_t(t) + shift);
                              tally.changedFrom = std::min(tally.changedFrom, now);
                              tally.changedTo = std::max(tally.changedTo, now + 1);
                            }
                          }
                        });
    };
    remapRange(0, tp.segments.front().oldFrom, 0);
    for (std::size_t i = 0; i < tp.segments.size(); ++i)
      remapRange(tp.segments[i].oldTo, i + 1 < tp.segments.size() ? tp.segments[i + 1].oldFrom : tp.oldSize,
                 tp.deltaAfter[i]);
    const Tally all = tallies.combine([](const Tally& a, const Tally& b) {
      return Tally{a.byKey + b.byKey, std::min(a.changedFrom, b.changedFrom), std::max(a.changedTo, b.changedTo)};
    });
    const std::uint64_t byKey = all.byKey, changedFrom = all.changedFrom, changedTo = all.changedTo;
    st.cornersByKey = byKey;
    // Triangles: the rows written, the runs moved (all after the first row when sizes changed),
    // and the kept triangles whose corners changed.
    st.triangles.from = std::min(changedFrom, tp.newFrom.front());
    st.triangles.to = tp.deltaAfter.back() != 0 ? tp.newSize
                                                 : std::max(changedTo, tp.newFrom.back() + tp.segments.back().count);
  }
  st.vertices.from = vp.newFrom.front();
  st.vertices.to = vp.deltaAfter.back() != 0 ? vp.newSize : vp.newFrom.back() + vp.segments.back().count;

  // 4. The vertices.
  st.verticesMoved = applyPlan(vp, m.positions, piece.positions.data());
  applyPlan(vp, m.edgeKeys, piece.edgeKeys.data());
  if (normals) applyPlan(vp, m.normals, piece.normals.data());
  if (colours) applyPlan(vp, m.colours, piece.colours.data());
  st.vertexRows = vp.segments.size();

  // 5. The new triangles' corners by key among the spliced vertices, then the triangles.
  std::vector<std::array<std::uint32_t, 3>> fresh(pieceTriangles);
  for (std::uint64_t t = 0; t < pieceTriangles; ++t)
    for (int c = 0; c < 3; ++c) {
      const std::uint64_t key = cornerKeys[3 * t + c];
      const auto at = std::lower_bound(m.edgeKeys.begin(), m.edgeKeys.end(), key);
      if (at == m.edgeKeys.end() || *at != key) broken("a re-run triangle names an edge with no vertex");
      fresh[t][c] = std::uint32_t(at - m.edgeKeys.begin());
    }
  st.trianglesMoved = applyPlan(tp, m.triangles, fresh.data());
  st.triangleRows = tp.segments.size();
}

}  // namespace blobvk::vk
