// See mpu_output.h. Three steps, each parallel:
// 1. Per MPU layer (z index), the scan of its rows: layers own consecutive ranges of the output
//    (rows of points by z, then y, then MPU column by x), so once each layer's first vertex and
//    triangle are known (a sum over MPUs) the layers are scanned independently.
// 2. Beside the scan, the output arrays are sized: for a fresh TriMesh this is the kernel's page
//    faults and zeroing, one task per array; a TriMesh meshed into again keeps its capacity.
// 3. Per MPU, its rows copied to their places; deferred corners resolved through the owner's
//    table of ranks for the points on its low faces.
// Placement depends only on indices, never on scheduling.
#include "blobvk/cpu_simd/mpu_output.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <limits>
#include <stdexcept>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace blobvk::cpu::detail {
// The owner of an edge referenced by a deferred corner (x, y or z past the owned range), the
// owner's point row holding it and its rank there.
DeferredTarget findDeferred(const glm::ivec3& mpus, const MpuResults& results, const MpuResult& r,
                            std::uint32_t code) {
  int q[3] = {int(code & 127u), int((code >> 7) & 127u), int((code >> 14) & 127u)};
  const int axis = int((code >> 21) & 3u);
  glm::ivec3 owner = r.mpu;
  for (int a = 0; a < 3; ++a) {
    if (q[a] >= r.owned[a]) {
      owner[a] += 1;
      q[a] -= r.owned[a];
    }
  }
  const int m = (owner.z * mpus.y + owner.y) * mpus.x + owner.x;
  const MpuResult* o = results[std::size_t(m)].get();
  std::uint8_t rank = kNoRank;
  if (o) {
    if (q[0] == 0)
      rank = o->faceX[std::size_t(q[2] * o->owned.y + q[1])][std::size_t(axis)];
    else if (q[1] == 0)
      rank = o->faceY[std::size_t(q[2] * o->owned.x + q[0])][std::size_t(axis)];
    else
      rank = o->faceZ[std::size_t(q[1] * o->owned.x + q[0])][std::size_t(axis)];
  }
  if (rank == kNoRank)
    throw std::logic_error("polygonizeMpu: a triangle refers to an edge its owner has no vertex for");
  return {std::size_t(m), std::size_t(q[2]) * std::size_t(o->owned.y) + std::size_t(q[1]), rank};
}

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Sizes an output array to n elements. Every element is overwritten by the copy, so old contents
// need not survive a reallocation; a large fresh array is advised onto transparent huge pages
// (where the system allows them on request), which makes its first touch one fault per 2 MiB
// instead of one per 4 KiB.
template <class T, class A>
void sizeOutput(std::vector<T, A>& v, std::size_t n) {
  if (v.capacity() < n) {
    std::vector<T, A>().swap(v);
    v.reserve(n);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(v.data()) + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(v.data()) + n * sizeof(T)) & ~(kHuge - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice only
#endif
  }
  v.resize(n);
}

// The owned point rows (axis 2: layers, axis 1: MPU rows) an MPU at index a along `axis` has, and
// its cell rows.
struct RowCounts {
  glm::ivec3 mpus, cells;
  int D;
  int ownedPoints(int a, int axis) const { return a == mpus[axis] - 1 ? cells[axis] - a * D + 1 : D; }
  int cellRows(int a, int axis) const { return std::min(D, cells[axis] - a * D); }
};

// Step 1 for one layer, for vertices (rows of owned points) or triangles (rows of cells). The
// MPUs of one slab (an MPU row y of the layer) share their rows; a row's place is the layer's
// running total in (row k, slab, row j) order plus the counts of the MPUs left of it in that row.
// Done as sequential passes over each MPU's row counts: offsets within the slab's rows, the
// bases of the slab rows, then the bases added.
template <bool kVertices>
void scanLayerRows(const RowCounts& rc, int mz, const MpuResults& results, MeshPlacement& p,
                   std::vector<std::uint32_t>& slabRows) {
  const auto rowsAlong = [&](int a, int axis) { return kVertices ? rc.ownedPoints(a, axis) : rc.cellRows(a, axis); };
  const auto rowStart = [](const MpuResult& r) {
    return kVertices ? r.vertexRowStart.data() : r.triangleRowStart.data();
  };
  std::vector<std::uint32_t>& base = kVertices ? p.vertexBase : p.triangleBase;
  const std::vector<std::size_t>& rowAt = kVertices ? p.vertexRowAt : p.triangleRowAt;
  const int rowsK = rowsAlong(mz, 2);
  const std::size_t layerColumns = std::size_t(mz) * std::size_t(rc.mpus.y);
  // Per slab, per row (k, j): the slab's total, then the row's global base.
  slabRows.assign(std::size_t(rc.mpus.y) * std::size_t(rc.D + 1) * std::size_t(rc.D + 1), 0);
  const auto slabTotals = [&](int my) { return slabRows.data() + std::size_t(my) * std::size_t(rc.D + 1) * std::size_t(rc.D + 1); };
  for (int my = 0; my < rc.mpus.y; ++my) {
    const std::size_t rows = std::size_t(rowsK) * std::size_t(rowsAlong(my, 1));
    std::uint32_t* __restrict total = slabTotals(my);
    for (std::uint32_t m : p.columns[layerColumns + std::size_t(my)]) {
      const std::uint32_t* __restrict start = rowStart(*results[m]);
      std::uint32_t* __restrict out = base.data() + rowAt[m];
      for (std::size_t row = 0; row < rows; ++row) {
        out[row] = total[row];
        total[row] += start[row + 1] - start[row];
      }
    }
  }
  std::uint64_t sum = kVertices ? p.layerVertices[std::size_t(mz)] : p.layerTriangles[std::size_t(mz)];
  for (int k = 0; k < rowsK; ++k)
    for (int my = 0; my < rc.mpus.y; ++my) {
      const int rowsJ = rowsAlong(my, 1);
      std::uint32_t* total = slabTotals(my) + std::size_t(k) * std::size_t(rowsJ);
      for (int j = 0; j < rowsJ; ++j) {
        const std::uint32_t count = total[j];
        total[j] = std::uint32_t(sum);
        sum += count;
      }
    }
  for (int my = 0; my < rc.mpus.y; ++my) {
    const std::size_t rows = std::size_t(rowsK) * std::size_t(rowsAlong(my, 1));
    const std::uint32_t* __restrict rowBase = slabTotals(my);
    for (std::uint32_t m : p.columns[layerColumns + std::size_t(my)]) {
      std::uint32_t* __restrict out = base.data() + rowAt[m];
      for (std::size_t row = 0; row < rows; ++row) out[row] += rowBase[row];
    }
  }
}

// Step 3 for one MPU: its rows of vertices and triangles (runs memcpy'd), corners made global.
void copyMpu(const glm::ivec3& mpus, const MpuResults& results, const MeshPlacement& p, std::size_t m,
             mesh::TriMesh& out, std::vector<std::uint32_t>& localToGlobal) {
  const MpuResult& r = *results[m];
  const glm::ivec3 owned = r.owned;
  localToGlobal.resize(r.positions.size());
  const std::uint32_t* vertexBase = p.vertexBase.data() + p.vertexRowAt[m];
  const std::size_t vertexRows = std::size_t(owned.y) * std::size_t(owned.z);
  for (std::size_t row = 0; row < vertexRows; ++row) {
    const std::uint32_t begin = r.vertexRowStart[row], end = r.vertexRowStart[row + 1];
    if (begin == end) continue;
    // Rows are short (a few vertices): element by element beats a library call per array.
    const std::uint32_t g = vertexBase[row] - begin;
    for (std::uint32_t v = begin; v < end; ++v) {
      out.positions[g + v] = r.positions[v];
      out.edgeKeys[g + v] = r.keys[v];
      localToGlobal[v] = g + v;
    }
    if (!r.normals.empty())
      for (std::uint32_t v = begin; v < end; ++v) out.normals[g + v] = r.normals[v];
    if (!r.colours.empty())
      for (std::uint32_t v = begin; v < end; ++v) out.colours[g + v] = r.colours[v];
  }
  const std::uint32_t* triangleBase = p.triangleBase.data() + p.triangleRowAt[m];
  const std::size_t triangleRows = std::size_t(r.pts.y - 1) * std::size_t(r.pts.z - 1);
  const std::uint32_t* toGlobal = localToGlobal.data();
  const auto resolve = [&](std::uint32_t code) {
    const DeferredTarget d = findDeferred(mpus, results, r, code);
    return p.vertexBase[p.vertexRowAt[d.mpu] + d.row] + d.rank;
  };
  for (std::size_t row = 0; row < triangleRows; ++row) {
    const std::uint32_t begin = r.triangleRowStart[row], end = r.triangleRowStart[row + 1];
    std::array<std::uint32_t, 3>* dst = out.triangles.data() + triangleBase[row];
    for (std::uint32_t t = begin; t < end; ++t, ++dst) {
      const std::array<std::uint32_t, 3>& tri = r.triangles[t];
      if (((tri[0] | tri[1] | tri[2]) & kDeferred) == 0) {
        *dst = {toGlobal[tri[0]], toGlobal[tri[1]], toGlobal[tri[2]]};
        continue;
      }
      for (int v = 0; v < 3; ++v) {
        const std::uint32_t c = tri[std::size_t(v)];
        (*dst)[std::size_t(v)] = (c & kDeferred) ? resolve(c) : toGlobal[c];
      }
    }
  }
}

}  // namespace

void weldResults(const blobtree::GridSpec& grid, int mpuCells, const MpuResults& results, bool normals,
                 bool colours, MeshPlacement& p, mesh::TriMesh& out, WeldTimes* times) {
  auto t0 = Clock::now();
  const RowCounts rc{(grid.cells + mpuCells - 1) / mpuCells, grid.cells, mpuCells};
  const glm::ivec3 mpus = rc.mpus;
  // Serial, over MPUs only: totals per layer, each MPU's first row, the MPU columns of each row.
  p.columns.resize(std::size_t(mpus.y) * std::size_t(mpus.z));
  for (auto& list : p.columns) list.clear();
  p.vertexRowAt.assign(results.size(), 0);
  p.triangleRowAt.assign(results.size(), 0);
  p.layerVertices.assign(std::size_t(mpus.z) + 1, 0);
  p.layerTriangles.assign(std::size_t(mpus.z) + 1, 0);
  std::vector<std::uint32_t> withResult;
  std::size_t vertexRows = 0, triangleRows = 0;
  for (std::size_t m = 0; m < results.size(); ++m) {
    const MpuResult* r = results[m].get();
    if (!r) continue;
    withResult.push_back(std::uint32_t(m));
    p.columns[std::size_t(r->mpu.z) * std::size_t(mpus.y) + std::size_t(r->mpu.y)].push_back(std::uint32_t(m));
    p.vertexRowAt[m] = vertexRows, p.triangleRowAt[m] = triangleRows;
    vertexRows += std::size_t(r->owned.y) * std::size_t(r->owned.z);
    triangleRows += std::size_t(r->pts.y - 1) * std::size_t(r->pts.z - 1);
    p.layerVertices[std::size_t(r->mpu.z) + 1] += r->positions.size();
    p.layerTriangles[std::size_t(r->mpu.z) + 1] += r->triangles.size();
  }
  for (std::size_t z = 0; z < std::size_t(mpus.z); ++z) {
    p.layerVertices[z + 1] += p.layerVertices[z];
    p.layerTriangles[z + 1] += p.layerTriangles[z];
  }
  const std::uint64_t nv = p.layerVertices.back(), nt = p.layerTriangles.back();
  if (nv >= std::uint64_t(kDeferred)) throw std::length_error("polygonizeMpu: more than 2^31 vertices");
  if (nt > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("polygonizeMpu: more than 2^32 triangles");
  p.vertexBase.resize(vertexRows);
  p.triangleBase.resize(triangleRows);
  tbb::parallel_invoke(
      [&] {
        tbb::enumerable_thread_specific<std::vector<std::uint32_t>> slabRows;
        tbb::parallel_for(0, mpus.z, [&](int mz) {
          scanLayerRows<true>(rc, mz, results, p, slabRows.local());
          scanLayerRows<false>(rc, mz, results, p, slabRows.local());
        });
      },
      [&] { sizeOutput(out.positions, nv); }, [&] { sizeOutput(out.edgeKeys, nv); },
      [&] { normals ? sizeOutput(out.normals, nv) : out.normals.clear(); },
      [&] { colours ? sizeOutput(out.colours, nv) : out.colours.clear(); },
      [&] { sizeOutput(out.triangles, nt); });
  if (times) times->msScan = msSince(t0);

  t0 = Clock::now();
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> localToGlobal;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, withResult.size(), 1), [&](const auto& range) {
    std::vector<std::uint32_t>& map = localToGlobal.local();
    for (std::size_t i = range.begin(); i != range.end(); ++i) copyMpu(mpus, results, p, withResult[i], out, map);
  });
  if (times) times->msCopy = msSince(t0);
}

std::uint32_t resolveDeferred(const glm::ivec3& mpus, int pointsY, const MpuResults& results,
                              const std::uint32_t* vertexRows, const MpuResult& r, std::uint32_t code) {
  const DeferredTarget d = findDeferred(mpus, results, r, code);
  const MpuResult& o = *results[d.mpu];
  const std::size_t gz = std::size_t(o.lo.z) + d.row / std::size_t(o.owned.y);
  const std::size_t gy = std::size_t(o.lo.y) + d.row % std::size_t(o.owned.y);
  return vertexRows[(gz * std::size_t(pointsY) + gy) * std::size_t(mpus.x) + std::size_t(o.mpu.x)] + d.rank;
}

}  // namespace blobvk::cpu::detail
