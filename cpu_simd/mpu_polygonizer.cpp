// MPU polygonizer (see mpu_polygonizer.h). A parallel pass over MPUs, then the welding:
//
// 1. Per MPU (parallel): early discard by interval bounds; field cache of its (D+1)^3 grid points
//    in SIMD batches; case index per cell; one vertex per crossing edge that the MPU *owns* (the
//    edge's start point lies in the MPU's half-open point range [lo, lo + D), the last MPU along
//    an axis also owning the grid's far plane); triangles whose corners are local vertex ids or,
//    for edges owned by a neighbour above, a deferred reference (the point and axis). The MPU's
//    result delimits its point rows (k, j) of vertices and its cell rows of triangles.
// 2. The welding (mpu_output.cpp): a scan in (row, MPU column) order, which is exactly the
//    global edge-key order of vertices (rows of points, x increasing, axes 0..2) and the cell
//    order of triangles, gives every row segment its final place; each MPU's rows are copied
//    there and deferred references resolved.
// Placement depends only on indices, never on scheduling: the output is the same for any
// thread count, and equal to polygonizeReference's since the fields are bit-identical.
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/mpu_attributes.h"
#include "blobvk/cpu_simd/mpu_output.h"
#include "blobvk/cpu_simd/mpu_results.h"
#include "blobvk/cpu_simd/mpu_triangles.h"

#include "blobvk/blobtree/gradient.h"

#include "blobvk/cpu_simd/block_bounds.h"
#include "blobvk/cpu_simd/edge_crossing.h"
#include "blobvk/cpu_simd/row_bits.h"
#include "blobvk/cpu_simd/tape_pruning.h"

#include <tbb/combinable.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <atomic>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::cpu {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

using detail::kDeferred;
using detail::kNoRank;
using detail::MpuResult;

struct ThreadStats {
  std::uint64_t grid = 0, edge = 0, attribute = 0, blocks = 0;
  std::uint64_t discardedEmpty = 0, discardedFull = 0, empty = 0, full = 0, crossed = 0;
  std::uint64_t tapeInstructions = 0, subBlocks = 0, subBlocksClassified = 0;
  double discard = 0, prune = 0, field = 0, cells = 0, vertices = 0, attributes = 0;
};

struct Scratch {
  std::vector<float> x, y, z, field;
  std::vector<std::uint8_t> inside;
  std::vector<detail::RowBits> rows;  // per point row (k, j): inside flags as bits
  std::vector<std::uint32_t> vertexId;  // per (local point * 3 + axis); valid for crossing edges
  std::vector<detail::RowBits> cross;   // per owned point row: crossing edges of axes 0, 1, 2
  std::vector<std::uint8_t> edgeAxis;
  std::vector<float> t, lo, hi, flo, fhi, f, px, py, pz, nx, ny, nz, cr, cg, cb;
  std::vector<int> kept, active;
  detail::TriangleScratch triangles;  // the triangle phase's case table and triangle buffer
  // Sparse field cache, per point row: points of unclassified leaves, points classified inside.
  std::vector<detail::RowBits> needRows, classRows;
  struct Block {
    glm::ivec3 c0, c1;  // local cell range
  };
  std::vector<Block> blocks, nextBlocks;  // sparse field cache: one octree level, the next
  BlockBounds blockBounds;             // their interval bounds, over the MPU's field tape
  std::vector<double> boundX, boundY, boundZ, boundLo, boundHi;  // one level's centres, bounds
  std::unique_ptr<blobtree::Program> fieldTape, colourTape;  // this thread's pruned tapes
  // Tapes of the current group of MPUs (from the Program), and the MPUs' tapes when they are
  // pruned from the group's (a tape of a tape: makeTapeProgram of the group's records).
  std::unique_ptr<blobtree::Program> groupTape, groupColourTape, childTape, childColourTape;
  // Scratch outlives a mesh (MpuPolygonizer keeps it); the tapes are copies of one mesh's
  // Program (makeTapeProgram), so they are made again when the mesh is a new one.
  std::uint64_t tapesOf = 0;
  void startMesh(std::uint64_t mesh) {
    if (tapesOf == mesh) return;
    tapesOf = mesh;
    for (auto* tape : {&fieldTape, &colourTape, &groupTape, &groupColourTape, &childTape, &childColourTape})
      tape->reset();
  }
};

struct Context {
  const blobtree::Program& program;
  const blobtree::GridSpec& grid;
  const MpuOptions& options;
  SimdLevel level;
  int width;
  int D;
  glm::ivec3 mpus;     // MPUs per axis
  glm::ivec3 points;   // grid points per axis
  // Per MPU: on entry a previous mesh's result whose arrays may be reused (or null), on exit
  // this mesh's (null: no surface).
  std::vector<std::unique_ptr<MpuResult>> results;
  std::uint64_t mesh = 0;  // which mesh this is, for Scratch::startMesh

  std::uint64_t blocks(std::size_t n) const { return (n + std::size_t(width) - 1) / std::size_t(width); }
};

// Illinois regula falsi on all edges of an MPU at once, step by step, mirroring
// reference_polygonizer.cpp's crossingParameter (same operations, same early stop).
void refineEdges(Context& ctx, const blobtree::Program& program, Scratch& s, std::size_t count,
                 const float* ax, const float* ay,
                 const float* az, const float* length, ThreadStats& st) {
  const float iso = layout::ISO_VALUE;
  for (int step = 0; step < ctx.options.refineSteps; ++step) {
    std::size_t n = 0;
    for (std::size_t e = 0; e < count; ++e) {
      if (!s.active[e]) continue;
      float p[3] = {ax[e], ay[e], az[e]};
      p[s.edgeAxis[e]] = p[s.edgeAxis[e]] + s.t[e] * length[e];
      s.px[n] = p[0], s.py[n] = p[1], s.pz[n] = p[2];
      s.kept[n] = int(e);  // reuse as the batch -> edge map
      ++n;
    }
    if (n == 0) break;
    evaluateFieldBatch(program, s.px.data(), s.py.data(), s.pz.data(), s.f.data(), n, ctx.level);
    st.edge += n;
    st.blocks += ctx.blocks(n);
    for (std::size_t b = 0; b < n; ++b) {
      const std::size_t e = std::size_t(s.kept[b]);
      const float f = s.f[b];
      if (f == iso) {
        s.active[e] = 0;
        continue;
      }
      int& keptSide = s.active[e];  // 1: none yet, 2: lo kept last, 3: hi kept last
      if ((f >= iso) == (s.flo[e] >= iso)) {
        s.lo[e] = s.t[e], s.flo[e] = f;
        if (keptSide == 3) s.fhi[e] = iso + (s.fhi[e] - iso) * 0.5f;
        keptSide = 3;
      } else {
        s.hi[e] = s.t[e], s.fhi[e] = f;
        if (keptSide == 2) s.flo[e] = iso + (s.flo[e] - iso) * 0.5f;
        keptSide = 2;
      }
      s.t[e] = crossingWithinEdge(s.lo[e] + (iso - s.flo[e]) / (s.fhi[e] - s.flo[e]) * (s.hi[e] - s.lo[e]));
    }
  }
}

// `bounds`: the Program or a tape exact over a box containing this MPU (its group's), for the
// early discard. `group`: when set, the MPU's tapes are pruned from the group's tapes (field,
// and colour when colours are on) instead of from the whole Program.
struct GroupTapes {
  const blobtree::Program* field = nullptr;
  const blobtree::Program* colour = nullptr;
};

// `reuse`: a result whose arrays this MPU's may take over (their capacity), or null.
BLOBVK_POPCNT_CLONES std::unique_ptr<MpuResult> processMpu(Context& ctx, int m, const blobtree::Program& bounds,
                                      const GroupTapes& group, Scratch& s, ThreadStats& st,
                                      std::unique_ptr<MpuResult> reuse) {
  const blobtree::GridSpec& grid = ctx.grid;
  const int D = ctx.D;
  const glm::ivec3 mi(m % ctx.mpus.x, (m / ctx.mpus.x) % ctx.mpus.y, m / (ctx.mpus.x * ctx.mpus.y));
  const glm::ivec3 lo = mi * D;
  const glm::ivec3 hiCell = glm::min(lo + D, grid.cells);
  const glm::ivec3 pts = hiCell - lo + 1;
  glm::ivec3 owned = pts - 1;
  for (int a = 0; a < 3; ++a)
    if (mi[a] == ctx.mpus[a] - 1) owned[a] = pts[a];
  const float iso = layout::ISO_VALUE;

  auto t0 = Clock::now();
  if (ctx.options.earlyDiscard) {
    const glm::vec3 blo = grid.point(lo.x, lo.y, lo.z), bhi = grid.point(hiCell.x, hiCell.y, hiCell.z);
    const FieldInterval f = fieldBounds(bounds, glm::dvec3(blo), glm::dvec3(bhi));
    st.discard += msSince(t0);
    if (f.hi < iso) {
      ++st.discardedEmpty;
      return nullptr;
    }
    if (f.lo >= iso) {
      ++st.discardedFull;
      return nullptr;
    }
  }

  // ---- the MPU's tapes: the code specialised to its box (tape_pruning.h) ----
  t0 = Clock::now();
  const blobtree::Program* fieldProgram = &ctx.program;
  const blobtree::Program* colourProgram = &ctx.program;
  if (ctx.options.pruneTapes) {
    if (!s.fieldTape) {
      s.fieldTape = std::make_unique<blobtree::Program>(makeTapeProgram(ctx.program));
      s.colourTape = std::make_unique<blobtree::Program>(*s.fieldTape);
    }
    // Every point evaluated for this MPU: grid points, edge points and normal samples p +- h.
    const glm::dvec3 margin(2.0 * double(ctx.options.normalStep));
    const glm::dvec3 blo = glm::dvec3(grid.point(lo.x, lo.y, lo.z)) - margin;
    const glm::dvec3 bhi = glm::dvec3(grid.point(hiCell.x, hiCell.y, hiCell.z)) + margin;
    if (group.field) {
      // The group's tapes are exact over this MPU's box too; pruning them is much shorter.
      if (!s.childTape) {
        s.childTape = std::make_unique<blobtree::Program>(makeTapeProgram(*group.field));
        s.childColourTape = std::make_unique<blobtree::Program>(*s.childTape);
      }
      specialiseTape(*group.field, blo, bhi, TapeUse::Field, *s.childTape);
      fieldProgram = s.childTape.get();
      if (ctx.options.colours) {
        specialiseTape(*group.colour, blo, bhi, TapeUse::FieldColour, *s.childColourTape);
        colourProgram = s.childColourTape.get();
      }
    } else {
      specialiseTapes(ctx.program, blo, bhi, *s.fieldTape,
                      ctx.options.colours ? s.colourTape.get() : nullptr);
      fieldProgram = s.fieldTape.get();
      if (ctx.options.colours) colourProgram = s.colourTape.get();
    }
    st.tapeInstructions += fieldProgram->code.size();
  }
  st.prune += msSince(t0);

  // ---- field cache, x fastest ----
  t0 = Clock::now();
  const std::size_t sx = 1, sy = std::size_t(pts.x), sz = std::size_t(pts.x) * std::size_t(pts.y);
  const std::size_t N = sz * std::size_t(pts.z);
  s.x.resize(N), s.y.resize(N), s.z.resize(N), s.field.resize(N);
  if (s.inside.size() < N + 16) s.inside.resize(N + 16);  // packRow reads up to 15 bytes past a row
  if (s.f.size() < N) s.f.resize(N);
  float cx[66], cy[66], cz[66];  // the grid's own coordinate expression, per axis (+1 spare)
  for (int i = 0; i < pts.x; ++i) cx[i] = grid.point(lo.x + i, 0, 0).x;
  for (int j = 0; j < pts.y; ++j) cy[j] = grid.point(0, lo.y + j, 0).y;
  for (int k = 0; k < pts.z; ++k) cz[k] = grid.point(0, 0, lo.z + k).z;
  const int B = ctx.options.subBlockCells;
  const glm::ivec3 cellsHere = pts - 1;
  if (B > 0 && B < std::max({cellsHere.x, cellsHere.y, cellsHere.z})) {
    // Sparse: the MPU is cut in halves recursively (an octree down to blocks of B cells); a
    // block whose interval bound is entirely outside or inside gives its points their side
    // without evaluating them, the others are cut again, and the points of the leaves left
    // unclassified are evaluated. Every grid edge lies in some leaf or classified block and a
    // classified one has no crossing edge, so every field value a vertex needs is evaluated.
    // Per point row: the points to evaluate (bits of unclassified leaves) and the points that a
    // classified block puts inside. Word operations per block row, no per-point writes.
    const std::size_t rowCount = std::size_t(pts.y) * std::size_t(pts.z);
    for (auto* rows : {&s.needRows, &s.classRows}) {  // memset: assign's 128-bit fill is a loop
      rows->resize(rowCount);
      std::memset(static_cast<void*>(rows->data()), 0, rowCount * sizeof(detail::RowBits));
    }
    using Block = Scratch::Block;
    s.blockBounds.reset(*fieldProgram, glm::dvec3(cx[0], cy[0], cz[0]),
                        glm::dvec3(cx[cellsHere.x], cy[cellsHere.y], cz[cellsHere.z]));
    // Level by level (all blocks of one size, then their children): BlockBounds caches the
    // per-size parts of the bound, and one level's blocks share a size.
    s.blocks.clear();
    s.blocks.push_back({glm::ivec3(0), cellsHere});
    bool root = true;
    while (!s.blocks.empty()) {
      s.nextBlocks.clear();
      const std::size_t count = s.blocks.size();
      if (!root) {  // the MPU itself was bounded by the early discard
        // One batch per level: centres, and the largest half extent (a level's blocks differ
        // by a cell at most, at odd extents; a larger box is still a conservative one).
        for (auto* v : {&s.boundX, &s.boundY, &s.boundZ, &s.boundLo, &s.boundHi}) v->resize(count);
        glm::dvec3 half(0.0);
        for (std::size_t b = 0; b < count; ++b) {
          const glm::ivec3 c0 = s.blocks[b].c0, c1 = s.blocks[b].c1;
          const glm::dvec3 blo(cx[c0.x], cy[c0.y], cz[c0.z]), bhi(cx[c1.x], cy[c1.y], cz[c1.z]);
          s.boundX[b] = (blo.x + bhi.x) * 0.5, s.boundY[b] = (blo.y + bhi.y) * 0.5;
          s.boundZ[b] = (blo.z + bhi.z) * 0.5;
          half = glm::max(half, (bhi - blo) * 0.5);
        }
        s.blockBounds(count, s.boundX.data(), s.boundY.data(), s.boundZ.data(), half,
                      s.boundLo.data(), s.boundHi.data());
        st.subBlocks += count;
      }
      for (std::size_t b = 0; b < count; ++b) {
        const Block blk = s.blocks[b];
        const glm::ivec3 c0 = blk.c0, c1 = blk.c1;
        const int side = root ? -1 : s.boundHi[b] < iso ? 0 : s.boundLo[b] >= iso ? 1 : -1;
        const glm::ivec3 extent = c1 - c0;
        if (side < 0 && std::max({extent.x, extent.y, extent.z}) > B) {
          // Halve every axis longer than a leaf.
          int cuts[3][3], parts[3];
          for (int a = 0; a < 3; ++a) {
            cuts[a][0] = c0[a];
            if (extent[a] > B) {
              cuts[a][1] = c0[a] + (extent[a] + 1) / 2, cuts[a][2] = c1[a], parts[a] = 2;
            } else {
              cuts[a][1] = c1[a], parts[a] = 1;
            }
          }
          for (int z = 0; z < parts[2]; ++z)
            for (int y = 0; y < parts[1]; ++y)
              for (int x = 0; x < parts[0]; ++x)
                s.nextBlocks.push_back({glm::ivec3(cuts[0][x], cuts[1][y], cuts[2][z]),
                                        glm::ivec3(cuts[0][x + 1], cuts[1][y + 1], cuts[2][z + 1])});
          continue;
        }
        if (side >= 0) ++st.subBlocksClassified;
        if (side == 0) continue;  // outside: its points' bits stay clear
        // Field values are read on crossing edges only: for a classified block the side is enough.
        detail::RowBits* target = side < 0 ? s.needRows.data() : s.classRows.data();
        const detail::RowBits span = detail::lowBits(c1.x + 1) & ~detail::lowBits(c0.x);
        for (int k = c0.z; k <= c1.z; ++k)
          for (int j = c0.y; j <= c1.y; ++j) target[std::size_t(k) * std::size_t(pts.y) + std::size_t(j)] |= span;
      }
      root = false;
      std::swap(s.blocks, s.nextBlocks);
    }
    // The points to evaluate, row by row: y and z are the row's, x walks the row's set bits.
    std::size_t n = 0;
    {
      float* __restrict px = s.x.data();
      float* __restrict py = s.y.data();
      float* __restrict pz = s.z.data();
      for (int k = 0; k < pts.z; ++k)
        for (int j = 0; j < pts.y; ++j) {
          const detail::RowBits need = s.needRows[std::size_t(k) * std::size_t(pts.y) + std::size_t(j)];
          if (!need) continue;
          const std::size_t c = std::size_t(detail::popCount(need));
          std::fill(py + n, py + n + c, cy[j]);
          std::fill(pz + n, pz + n + c, cz[k]);
          detail::forEachBit(need, [&](int i) { px[n++] = cx[i]; });
        }
    }
    evaluateFieldBatch(*fieldProgram, s.x.data(), s.y.data(), s.z.data(), s.f.data(), n,
                       ctx.level);
    // Back into the cache in the same order; a point's evaluated side wins over a classified
    // block's (they agree: the bound is conservative).
    s.rows.resize(rowCount);
    {
      const float* __restrict f = s.f.data();
      float* __restrict field = s.field.data();
      std::size_t e = 0;
      for (std::size_t row = 0; row < rowCount; ++row) {
        const detail::RowBits need = s.needRows[row];
        std::uint64_t in[2] = {0, 0};
        float* fieldRow = field + row * sy;
        detail::forEachBit(need, [&](int i) {
          fieldRow[i] = f[e];
          in[i >> 6] |= std::uint64_t(f[e] >= iso) << (i & 63);
          ++e;
        });
        s.rows[row] = (s.classRows[row] & ~need) | detail::RowBits(in[0]) | (detail::RowBits(in[1]) << 64);
      }
    }
    st.grid += n;
    st.blocks += ctx.blocks(n);
  } else {
    std::size_t p = 0;
    for (int k = 0; k < pts.z; ++k)
      for (int j = 0; j < pts.y; ++j)
        for (int i = 0; i < pts.x; ++i, ++p) s.x[p] = cx[i], s.y[p] = cy[j], s.z[p] = cz[k];
    evaluateFieldBatch(*fieldProgram, s.x.data(), s.y.data(), s.z.data(), s.field.data(), N,
                       ctx.level);
    st.grid += N;
    st.blocks += ctx.blocks(N);
    // Restrict: bytes may alias anything, and without it this loop is not vectorised.
    const float* __restrict field = s.field.data();
    std::uint8_t* __restrict inside = s.inside.data();
    for (std::size_t p2 = 0; p2 < N; ++p2) inside[p2] = field[p2] >= iso ? 1 : 0;
    // Inside flags as one bit mask per point row.
    const std::size_t rowCount = std::size_t(pts.y) * std::size_t(pts.z);
    s.rows.resize(rowCount);
    for (std::size_t row = 0; row < rowCount; ++row) s.rows[row] = detail::packRow(s.inside.data() + row * sy, pts.x);
  }
  // From here on the inside flags are the row bit masks: crossing edges and mixed cells of a
  // row are a few word operations, and only their set bits are visited below.
  const std::size_t rowCount = std::size_t(pts.y) * std::size_t(pts.z);
  const detail::RowBits fullRow = detail::lowBits(pts.x);
  bool anyInside = false, allInside = true;
  for (std::size_t row = 0; row < rowCount; ++row) {
    const detail::RowBits bits = s.rows[row];
    anyInside |= bits != 0;
    allInside &= bits == fullRow;
  }
  st.field += msSince(t0);
  if (!anyInside) {
    ++st.empty;
    return nullptr;
  }
  if (allInside) {
    ++st.full;
    return nullptr;
  }
  const auto rowBits = [&](int j, int k) {
    return s.rows[std::size_t(k) * std::size_t(pts.y) + std::size_t(j)];
  };
  ++st.crossed;

  // ---- vertices on owned crossing edges, in edge-key order ----
  t0 = Clock::now();
  std::unique_ptr<MpuResult> r = reuse ? std::move(reuse) : std::make_unique<MpuResult>();
  r->mpu = mi, r->lo = lo, r->pts = pts, r->owned = owned;
  if (s.vertexId.size() < N * 3) s.vertexId.resize(N * 3);
  const std::size_t ownedRows = std::size_t(owned.y) * std::size_t(owned.z);
  r->vertexRowStart.resize(ownedRows + 1);
  const std::size_t strides[3] = {sx, sy, sz};
  const detail::RowBits ownedMask = detail::lowBits(owned.x);
  const detail::RowBits xEdgeMask = detail::lowBits(std::min(owned.x, pts.x - 1));
  // Crossing edges per owned row and axis: edge (i, axis) crosses when its two end points
  // differ; i < owned.x, and an x edge also needs i + 1 < pts.x. Counted first, so every
  // array below is sized once and written in place.
  s.cross.resize(ownedRows * 3);
  std::size_t nv = 0;
  for (int k = 0; k < owned.z; ++k)
    for (int j = 0; j < owned.y; ++j) {
      const std::size_t row = std::size_t(k) * std::size_t(owned.y) + std::size_t(j);
      const detail::RowBits here = rowBits(j, k);
      detail::RowBits* cross = &s.cross[row * 3];
      cross[0] = (here ^ (here >> 1)) & xEdgeMask;
      cross[1] = j + 1 < pts.y ? (here ^ rowBits(j + 1, k)) & ownedMask : detail::RowBits(0);
      cross[2] = k + 1 < pts.z ? (here ^ rowBits(j, k + 1)) & ownedMask : detail::RowBits(0);
      r->vertexRowStart[row] = std::uint32_t(nv);
      nv += std::size_t(detail::popCount(cross[0]) + detail::popCount(cross[1]) + detail::popCount(cross[2]));
    }
  r->vertexRowStart.back() = std::uint32_t(nv);
  if (s.t.size() < nv)
    for (auto* v : {&s.t, &s.lo, &s.hi, &s.flo, &s.fhi, &s.px, &s.py, &s.pz, &s.nx, &s.ny,
                    &s.nz, &s.cr, &s.cg, &s.cb})
      v->resize(nv);
  if (s.f.size() < nv) s.f.resize(nv);
  if (s.edgeAxis.size() < nv) s.edgeAxis.resize(nv), s.kept.resize(nv), s.active.resize(nv);
  r->keys.resize(nv);
  r->positions.resize(nv);
  // Refinement needs each edge's start point and length; without it the position is final here.
  const bool refine = ctx.options.refineSteps > 0;
  float* ax = s.nx.data();  // start points and lengths borrow the normal buffers
  float* ay = s.ny.data();
  float* az = s.nz.data();
  float* length = s.cr.data();
  {
    std::uint32_t* __restrict vertexId = s.vertexId.data();
    const float* __restrict field = s.field.data();
    std::uint64_t* __restrict keys = r->keys.data();
    mesh::Float3* __restrict positions = r->positions.data();
    float* __restrict px = s.px.data();
    float* __restrict py = s.py.data();
    float* __restrict pz = s.pz.data();
    float* __restrict tt = s.t.data();
    std::uint8_t* __restrict edgeAxis = s.edgeAxis.data();
    // Low-face rank tables for the neighbours below (rank: the vertex's place in its row),
    // filled as the vertices of points with i, j or k == 0 are made.
    // Every byte kNoRank: one memset each (a fill of 3-byte elements is an element loop).
    static_assert(sizeof(std::array<std::uint8_t, 3>) == 3 && kNoRank == 0xff);
    const auto clearFace = [](std::vector<std::array<std::uint8_t, 3>>& face, std::size_t n) {
      face.resize(n);
      std::memset(face.data(), 0xff, n * 3);
    };
    clearFace(r->faceX, std::size_t(owned.y) * std::size_t(owned.z));
    clearFace(r->faceY, std::size_t(owned.x) * std::size_t(owned.z));
    clearFace(r->faceZ, std::size_t(owned.x) * std::size_t(owned.y));
    std::uint32_t e = 0;
    for (int k = 0; k < owned.z; ++k) {
      const float lz = cz[k + 1 < pts.z ? k + 1 : k] - cz[k];
      for (int j = 0; j < owned.y; ++j) {
        const std::size_t row = std::size_t(k) * std::size_t(owned.y) + std::size_t(j);
        const std::size_t base = std::size_t(k) * sz + std::size_t(j) * sy;
        const detail::RowBits* cross = &s.cross[row * 3];
        // Edge keys of this row: pointIndex * 3 + axis, the point index growing by 1 along x.
        const std::uint64_t rowKey = grid.edgeKey(lo.x, lo.y + j, lo.z + k, 0);
        const float ly = cy[j + 1 < pts.y ? j + 1 : j] - cy[j];
        const std::uint32_t rowBegin = e;
        std::array<std::uint8_t, 3>& faceX = r->faceX[row];
        std::array<std::uint8_t, 3>* faceY = j == 0 ? &r->faceY[std::size_t(k) * std::size_t(owned.x)] : nullptr;
        std::array<std::uint8_t, 3>* faceZ = k == 0 ? &r->faceZ[std::size_t(j) * std::size_t(owned.x)] : nullptr;
        detail::forEachBit(cross[0] | cross[1] | cross[2], [&](int i) {
          const std::size_t p = base + std::size_t(i);
          const float fa = field[p];
          for (int axis = 0; axis < 3; ++axis) {
            if (!detail::bitAt(cross[axis], i)) continue;
            const std::uint8_t rank = std::uint8_t(e - rowBegin);
            if (i == 0) faceX[std::size_t(axis)] = rank;
            if (faceY) faceY[i][std::size_t(axis)] = rank;
            if (faceZ) faceZ[i][std::size_t(axis)] = rank;
            vertexId[p * 3 + std::size_t(axis)] = e;
            edgeAxis[e] = std::uint8_t(axis);
            // Positions: the reference's expression, a[axis] + t * (b[axis] - a[axis]).
            const float len = axis == 0 ? cx[i + 1] - cx[i] : axis == 1 ? ly : lz;
            const float fb = field[p + strides[axis]];
            const float t = crossingWithinEdge((iso - fa) / (fb - fa));
            float q[3] = {cx[i], cy[j], cz[k]};
            if (refine) {
              ax[e] = q[0], ay[e] = q[1], az[e] = q[2], length[e] = len, tt[e] = t;
              s.lo[e] = 0.0f, s.hi[e] = 1.0f, s.flo[e] = fa, s.fhi[e] = fb, s.active[e] = 1;
            }
            q[axis] = q[axis] + t * len;
            positions[e] = {q[0], q[1], q[2]};
            px[e] = q[0], py[e] = q[1], pz[e] = q[2];
            keys[e] = rowKey + 3u * std::uint64_t(i) + std::uint64_t(axis);
            ++e;
          }
        });
      }
    }
  }
  if (refine) {
    refineEdges(ctx, *fieldProgram, s, nv, ax, ay, az, length, st);
    for (std::size_t e = 0; e < nv; ++e) {
      float q[3] = {ax[e], ay[e], az[e]};
      const int axis = s.edgeAxis[e];
      q[axis] = q[axis] + s.t[e] * length[e];
      r->positions[e] = {q[0], q[1], q[2]};
      s.px[e] = q[0], s.py[e] = q[1], s.pz[e] = q[2];
    }
  }
  st.vertices += msSince(t0);

  // ---- attributes in SIMD batches: one analytic-gradient pass gives normal and colour ----
  t0 = Clock::now();
  if (ctx.options.normals || ctx.options.colours) {
    // The colour tape computes the field tape's bits too (and its gradient: what pruning drops is
    // exactly zero over the MPU, value and gradient), so one pass serves both attributes.
    const bool colours = ctx.options.colours;
    evaluateGradientBatch(colours ? *colourProgram : *fieldProgram, s.px.data(), s.py.data(), s.pz.data(), s.f.data(),
                          s.nx.data(), s.ny.data(), s.nz.data(), colours ? s.cr.data() : nullptr, s.cg.data(),
                          s.cb.data(), nv, ctx.level);
    st.attribute += nv;
    st.blocks += ctx.blocks(nv);
    if (ctx.options.normals) {
      r->normals.resize(nv);
      detail::outwardNormals(s.nx.data(), s.ny.data(), s.nz.data(), nv, r->normals.data());
    }
    if (colours) {
      r->colours.resize(nv);
      detail::interleave(s.cr.data(), s.cg.data(), s.cb.data(), nv, r->colours.data());
    }
  }
  st.attributes += msSince(t0);

  // ---- cells: case index per row of cells, triangles in cell order (mpu_triangles.cpp) ----
  t0 = Clock::now();
  detail::mpuTriangles(s.rows.data(), pts, owned, s.vertexId.data(), s.triangles, *r);
  st.cells += msSince(t0);
  return r;
}

// Hierarchical discard: a group of kGroupMpus^3 MPUs is bounded first with the whole Program;
// when it has no surface all its MPUs are discarded, otherwise their own bounds run on the
// group's pruned field tape (a few instructions instead of the whole Program). The tape is
// exact inside the group's box, so the bounds stay conservative and the mesh is unchanged.
constexpr int kGroupMpus = 2;

void processGroup(Context& ctx, int g, Scratch& s, ThreadStats& st) {
  const glm::ivec3 groups = (ctx.mpus + kGroupMpus - 1) / kGroupMpus;
  const glm::ivec3 gi(g % groups.x, (g / groups.x) % groups.y, g / (groups.x * groups.y));
  const glm::ivec3 m0 = gi * kGroupMpus, m1 = glm::min(m0 + kGroupMpus, ctx.mpus);
  const blobtree::Program* bounds = &ctx.program;
  GroupTapes tapes;
  const bool single = (m1 - m0) == glm::ivec3(1);
  if (ctx.options.earlyDiscard && !single) {
    const auto t0 = Clock::now();
    const glm::ivec3 c0 = m0 * ctx.D, c1 = glm::min(m1 * ctx.D, ctx.grid.cells);
    const glm::dvec3 blo(ctx.grid.point(c0.x, c0.y, c0.z)), bhi(ctx.grid.point(c1.x, c1.y, c1.z));
    const FieldInterval f = fieldBounds(ctx.program, blo, bhi);
    const float iso = layout::ISO_VALUE;
    if (f.hi < iso || f.lo >= iso) {
      const std::uint64_t count = std::uint64_t((m1 - m0).x) * std::uint64_t((m1 - m0).y) *
                                  std::uint64_t((m1 - m0).z);
      (f.hi < iso ? st.discardedEmpty : st.discardedFull) += count;
      st.discard += msSince(t0);
      for (int z = m0.z; z < m1.z; ++z)
        for (int y = m0.y; y < m1.y; ++y)
          for (int x = m0.x; x < m1.x; ++x) ctx.results[std::size_t((z * ctx.mpus.y + y) * ctx.mpus.x + x)].reset();
      return;
    }
    if (!s.groupTape) {
      s.groupTape = std::make_unique<blobtree::Program>(makeTapeProgram(ctx.program));
      s.groupColourTape = std::make_unique<blobtree::Program>(*s.groupTape);
    }
    const glm::dvec3 margin(2.0 * double(ctx.options.normalStep));
    const bool colourTape = ctx.options.pruneTapes && ctx.options.colours;
    specialiseTapes(ctx.program, blo - margin, bhi + margin, *s.groupTape,
                    colourTape ? s.groupColourTape.get() : nullptr);
    bounds = s.groupTape.get();
    if (ctx.options.pruneTapes) tapes = {s.groupTape.get(), s.groupColourTape.get()};
    st.discard += msSince(t0);
  }
  for (int z = m0.z; z < m1.z; ++z)
    for (int y = m0.y; y < m1.y; ++y)
      for (int x = m0.x; x < m1.x; ++x) {
        const int m = (z * ctx.mpus.y + y) * ctx.mpus.x + x;
        std::unique_ptr<MpuResult>& slot = ctx.results[std::size_t(m)];
        slot = processMpu(ctx, m, *bounds, tapes, s, st, std::move(slot));
      }
}

// What one mesh needs that can outlive it: per-thread scratch, every MPU's result (their arrays
// are reused by the same MPU of the next mesh) and the welding's placement.
struct MeshState {
  tbb::combinable<Scratch> scratch;
  detail::MpuResults results;
  detail::MeshPlacement placement;
};

std::uint64_t nextMeshId() {
  static std::atomic<std::uint64_t> meshes{0};
  return ++meshes;
}

void validate(const blobtree::GridSpec& grid, const MpuOptions& options) {
  if (!(grid.cellSize > 0.0f))
    throw std::invalid_argument("polygonizeMpu: cell size must be positive, got " +
                                std::to_string(grid.cellSize));
  if (grid.cells.x < 0 || grid.cells.y < 0 || grid.cells.z < 0)
    throw std::invalid_argument("polygonizeMpu: negative cell count");
  if (options.mpuCells < 2 || options.mpuCells > 64)
    throw std::invalid_argument("polygonizeMpu: mpuCells must be in [2, 64], got " +
                                std::to_string(options.mpuCells));
  if (options.refineSteps < 0) throw std::invalid_argument("polygonizeMpu: refineSteps must be >= 0");
  if (options.threads < 0) throw std::invalid_argument("polygonizeMpu: threads must be >= 0");
}

// The whole mesh into `out` (its arrays resized), with `state` from the previous mesh or fresh.
void polygonizeInto(MeshState& state, const blobtree::Program& program, const blobtree::GridSpec& grid,
                    const MpuOptions& options, MpuStats* stats, mesh::TriMesh& out) {
  const auto tStart = Clock::now();
  validate(grid, options);
  MpuStats local;
  MpuStats& st = stats ? *stats : local;
  st = MpuStats{};
  const SimdLevel level = options.simd.value_or(bestSimdLevel());
  if (!simdLevelSupported(level))
    throw std::invalid_argument(std::string("polygonizeMpu: SIMD level ") + toString(level) +
                                " is not supported by this CPU");
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  st.mpuCells = options.mpuCells, st.threads = threads, st.simd = level;

  if (grid.cells.x == 0 || grid.cells.y == 0 || grid.cells.z == 0) {
    out = mesh::TriMesh{};
    state.results.clear();
    return;
  }

  const int D = options.mpuCells;
  Context ctx{program, grid, options, level, simdWidth(level), D,
              (grid.cells + D - 1) / D, grid.points(), std::move(state.results), nextMeshId()};
  const std::size_t mpuCount = std::size_t(ctx.mpus.x) * std::size_t(ctx.mpus.y) * std::size_t(ctx.mpus.z);
  ctx.results.resize(mpuCount);
  st.mpus = mpuCount;
  st.msSetup = msSince(tStart);

  tbb::task_arena arena(threads);
  tbb::combinable<ThreadStats> perThread;
  auto t0 = Clock::now();
  const glm::ivec3 groups = (ctx.mpus + kGroupMpus - 1) / kGroupMpus;
  const std::size_t groupCount = std::size_t(groups.x) * std::size_t(groups.y) * std::size_t(groups.z);
  std::atomic<std::size_t> groupsDone{0};
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groupCount, 1), [&](const auto& range) {
      ThreadStats& ts = perThread.local();
      Scratch& s = state.scratch.local();
      s.startMesh(ctx.mesh);
      for (std::size_t g = range.begin(); g != range.end(); ++g) {
        processGroup(ctx, int(g), s, ts);
        if (options.progress) options.progress(++groupsDone, groupCount);
      }
    });
  });
  st.msMpus = msSince(t0);
  state.results = std::move(ctx.results);

  detail::WeldTimes weld;
  arena.execute([&] {
    detail::weldResults(grid, D, state.results, options.normals, options.colours, state.placement, out, &weld);
  });
  st.msPrefix = weld.msScan, st.msScatter = weld.msCopy;

  perThread.combine_each([&](const ThreadStats& t) {
    st.gridEvaluations += t.grid, st.edgeEvaluations += t.edge, st.attributeEvaluations += t.attribute;
    st.simdBlocks += t.blocks;
    st.discardedEmpty += t.discardedEmpty, st.discardedFull += t.discardedFull;
    st.empty += t.empty, st.full += t.full, st.crossed += t.crossed;
    st.tapeInstructions += t.tapeInstructions;
    st.subBlocks += t.subBlocks, st.subBlocksClassified += t.subBlocksClassified;
    st.cpuDiscard += t.discard, st.cpuPrune += t.prune, st.cpuField += t.field, st.cpuCells += t.cells;
    st.cpuVertices += t.vertices, st.cpuAttributes += t.attributes;
  });
  st.pointEvaluations = st.gridEvaluations + st.edgeEvaluations + st.attributeEvaluations;
  st.vertices = out.positions.size(), st.triangles = out.triangles.size();
  st.fvept = st.triangles ? double(st.pointEvaluations) / double(st.triangles) : 0.0;
  st.fveptSimd = st.triangles ? double(st.simdBlocks) / double(st.triangles) : 0.0;
  st.msTotal = msSince(tStart);
}

}  // namespace

namespace detail {

void repolygonizeMpus(const blobtree::Program& program, const blobtree::GridSpec& grid,
                      const MpuOptions& options, const std::vector<std::uint32_t>& which,
                      MpuResults& results, MpuStats* stats) {
  const SimdLevel level = options.simd.value_or(bestSimdLevel());
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  const int D = options.mpuCells;
  Context ctx{program, grid, options, level, simdWidth(level), D,
              (grid.cells + D - 1) / D, grid.points(), std::move(results), nextMeshId()};
  tbb::task_arena arena(threads);
  tbb::combinable<ThreadStats> perThread;
  tbb::combinable<Scratch> scratch;
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, which.size(), 1), [&](const auto& range) {
      ThreadStats& ts = perThread.local();
      Scratch& s = scratch.local();
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        ctx.results[which[i]] = processMpu(ctx, int(which[i]), program, {}, s, ts, nullptr);
    });
  });
  results = std::move(ctx.results);
  if (stats) {
    perThread.combine_each([&](const ThreadStats& t) {
      stats->gridEvaluations += t.grid, stats->edgeEvaluations += t.edge;
      stats->attributeEvaluations += t.attribute;
      stats->discardedEmpty += t.discardedEmpty, stats->discardedFull += t.discardedFull;
      stats->empty += t.empty, stats->full += t.full, stats->crossed += t.crossed;
    });
    stats->mpus += which.size();
  }
}

mesh::TriMesh polygonizeMpuKeeping(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                   const MpuOptions& options, MpuStats* stats, MpuResults& results) {
  MeshState state;
  mesh::TriMesh mesh;
  polygonizeInto(state, program, grid, options, stats, mesh);
  results = std::move(state.results);
  return mesh;
}

}  // namespace detail

mesh::TriMesh polygonizeMpu(const blobtree::Program& program, const blobtree::GridSpec& grid,
                            const MpuOptions& options, MpuStats* stats) {
  MeshState state;
  mesh::TriMesh mesh;
  polygonizeInto(state, program, grid, options, stats, mesh);
  return mesh;
}

struct MpuPolygonizer::State : MeshState {};

MpuPolygonizer::MpuPolygonizer() : state_(std::make_unique<State>()) {}
MpuPolygonizer::~MpuPolygonizer() = default;
MpuPolygonizer::MpuPolygonizer(MpuPolygonizer&&) noexcept = default;
MpuPolygonizer& MpuPolygonizer::operator=(MpuPolygonizer&&) noexcept = default;

void MpuPolygonizer::polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const MpuOptions& options, mesh::TriMesh& out, MpuStats* stats) {
  polygonizeInto(*state_, program, grid, options, stats, out);
}

}  // namespace blobvk::cpu
