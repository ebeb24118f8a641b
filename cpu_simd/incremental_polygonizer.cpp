// IncrementalPolygonizer (see incremental_polygonizer.h).
//
// The mesh is laid out by segments: the vertices of point row (k, j) owned by MPU column a, in
// (k, j, a) order, and likewise the triangles of cell row (k, j). An update knows which MPUs
// changed, so it knows which segments are new; every other segment keeps its bytes and only
// moves by the change in size of the new segments before it. The splice therefore:
//  1. re-runs the dirty MPUs (their results replace the kept ones);
//  2. lists the dirty segments in global order; between them lie runs of clean segments, each
//     shifted by one delta; moves the runs in place (left-moving runs front to back, then
//     right-moving runs back to front, so no run overwrites one not yet moved);
//  3. writes the dirty segments from the new results;
//  4. for triangles, the "rewritten" MPUs are the dirty ones and those whose triangles refer to
//     a dirty neighbour's vertices (deferred corners, resolved through the neighbour's ranks):
//     their triangles are written again from their kept results. Every other triangle refers
//     only to clean vertices, so its corners move by the delta of the vertex run they lie in.
// Only the tail of the mesh after the first size change is touched, and only by memmove.
#include "blobvk/cpu_simd/incremental_polygonizer.h"

#include "blobvk/cpu_simd/mpu_results.h"

#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <optional>
#include <utility>
#include <stdexcept>
#include <vector>

namespace blobvk::cpu {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// A run of clean segments: old elements [from, from + count) go to from + delta.
struct Run {
  std::uint32_t from = 0, count = 0;
  std::int64_t delta = 0;
};

// A dirty segment: its index, its new element count, and the MPU row it comes from.
struct DirtySegment {
  std::size_t segment = 0;
  std::uint32_t count = 0;
  std::uint32_t mpu = 0, row = 0;
};

// Moves every run of `v` in place (see the file comment for why this order is safe).
template <class T, class A>
void moveRuns(std::vector<T, A>& v, const std::vector<Run>& runs, std::size_t oldSize, std::size_t newSize) {
  if (newSize > oldSize) v.resize(newSize);
  for (const Run& r : runs)
    if (r.delta < 0 && r.count) std::memmove(v.data() + (r.from + r.delta), v.data() + r.from, r.count * sizeof(T));
  for (auto it = runs.rbegin(); it != runs.rend(); ++it)
    if (it->delta > 0 && it->count)
      std::memmove(v.data() + (it->from + it->delta), v.data() + it->from, it->count * sizeof(T));
  if (newSize < oldSize) v.resize(newSize);
}

struct Plan {
  std::vector<Run> runs;                 // clean runs in order, zero deltas included
  std::vector<std::uint32_t> newStarts;  // per dirty segment (same order as the list)
  // The delta of the clean segments before dirty segment i (and, last, after every one).
  std::vector<std::int64_t> stretchDelta;
  std::uint32_t oldSize = 0, newSize = 0;
  std::uint64_t moved = 0;
};

// Runs and new starts from the scanned starts (size segments + 1) and the sorted dirty list;
// updates `starts` to the new layout.
Plan plan(std::vector<std::uint32_t>& starts, const std::vector<DirtySegment>& dirty) {
  Plan p;
  p.oldSize = starts.back();
  std::int64_t delta = 0;
  std::size_t next = 0;  // first segment of the current clean run
  const auto cleanRun = [&](std::size_t end) {
    const std::uint32_t from = starts[next], to = starts[end];
    if (to > from) {
      p.runs.push_back({from, to - from, delta});
      if (delta) p.moved += to - from;
    }
  };
  std::vector<std::int64_t> segmentDelta;  // the delta of each clean stretch, to shift starts
  std::vector<std::size_t> stretchEnd;
  for (const DirtySegment& d : dirty) {
    cleanRun(d.segment);
    segmentDelta.push_back(delta);
    stretchEnd.push_back(d.segment);
    p.newStarts.push_back(std::uint32_t(std::int64_t(starts[d.segment]) + delta));
    delta += std::int64_t(d.count) - std::int64_t(starts[d.segment + 1] - starts[d.segment]);
    next = d.segment + 1;
  }
  cleanRun(starts.size() - 1);
  p.stretchDelta = segmentDelta;
  p.stretchDelta.push_back(delta);
  p.newSize = std::uint32_t(std::int64_t(p.oldSize) + delta);
  // New starts: clean segments shift by their stretch's delta, dirty ones take theirs.
  std::size_t s = 0;
  for (std::size_t i = 0; i < dirty.size(); ++i) {
    if (segmentDelta[i])
      for (; s < stretchEnd[i]; ++s) starts[s] = std::uint32_t(std::int64_t(starts[s]) + segmentDelta[i]);
    s = dirty[i].segment;
    starts[s++] = p.newStarts[i];
  }
  if (delta)
    for (; s + 1 < starts.size(); ++s) starts[s] = std::uint32_t(std::int64_t(starts[s]) + delta);
  starts.back() = p.newSize;
  return p;
}

}  // namespace

struct IncrementalPolygonizer::State {
  blobtree::GridSpec grid;
  MpuOptions options;
  int D = 0;
  glm::ivec3 mpus{0}, points{0};
  bool ready = false;
  detail::MpuResults results;
  mesh::TriMesh mesh;
  // Scanned starts per segment, plus the total: vertex segments [(k * points.y + j) * mpus.x + a],
  // triangle segments [(k * cells.y + j) * mpus.x + a].
  std::vector<std::uint32_t> vertexStarts, triangleStarts;

  std::size_t mpuCount() const { return std::size_t(mpus.x) * std::size_t(mpus.y) * std::size_t(mpus.z); }
  glm::ivec3 mpuIndex(std::size_t m) const {
    return {int(m % std::size_t(mpus.x)), int((m / std::size_t(mpus.x)) % std::size_t(mpus.y)),
            int(m / (std::size_t(mpus.x) * std::size_t(mpus.y)))};
  }
  // Point rows (y, z) an MPU owns and cell rows it covers, as polygonizeMpu assigns them.
  glm::ivec3 owned(const glm::ivec3& mi) const {
    const glm::ivec3 lo = mi * D, hi = glm::min(lo + D, grid.cells);
    glm::ivec3 o = hi - lo;
    for (int a = 0; a < 3; ++a)
      if (mi[a] == mpus[a] - 1) o[a] += 1;
    return o;
  }
  glm::ivec3 cellsOf(const glm::ivec3& mi) const { return glm::min(mi * D + D, grid.cells) - mi * D; }
  std::size_t vertexSegment(int k, int j, int a) const {
    return (std::size_t(k) * std::size_t(points.y) + std::size_t(j)) * std::size_t(mpus.x) + std::size_t(a);
  }
  std::size_t triangleSegment(int k, int j, int a) const {
    return (std::size_t(k) * std::size_t(grid.cells.y) + std::size_t(j)) * std::size_t(mpus.x) + std::size_t(a);
  }

  void scanStarts() {
    vertexStarts.assign(std::size_t(points.z) * std::size_t(points.y) * std::size_t(mpus.x) + 1, 0u);
    triangleStarts.assign(std::size_t(grid.cells.z) * std::size_t(grid.cells.y) * std::size_t(mpus.x) + 1, 0u);
    for (const auto& r : results) {
      if (!r) continue;
      for (int k = 0; k < r->owned.z; ++k)
        for (int j = 0; j < r->owned.y; ++j) {
          const std::size_t row = std::size_t(k) * std::size_t(r->owned.y) + std::size_t(j);
          vertexStarts[vertexSegment(r->lo.z + k, r->lo.y + j, r->mpu.x)] = r->vertexRowStart[row + 1] - r->vertexRowStart[row];
        }
      const int ncy = r->pts.y - 1;
      for (int k = 0; k < r->pts.z - 1; ++k)
        for (int j = 0; j < ncy; ++j) {
          const std::size_t row = std::size_t(k) * std::size_t(ncy) + std::size_t(j);
          triangleStarts[triangleSegment(r->lo.z + k, r->lo.y + j, r->mpu.x)] =
              r->triangleRowStart[row + 1] - r->triangleRowStart[row];
        }
    }
    for (auto* starts : {&vertexStarts, &triangleStarts}) {
      std::uint32_t sum = 0;
      for (auto& c : *starts) {
        const std::uint32_t n = c;
        c = sum;
        sum += n;
      }
    }
  }
};

IncrementalPolygonizer::IncrementalPolygonizer(const blobtree::GridSpec& grid, const MpuOptions& options)
    : state_(std::make_unique<State>()) {
  state_->grid = grid;
  state_->options = options;
  state_->options.progress = options.progress;
}

IncrementalPolygonizer::~IncrementalPolygonizer() = default;

const mesh::TriMesh& IncrementalPolygonizer::mesh() const { return state_->mesh; }
const blobtree::GridSpec& IncrementalPolygonizer::grid() const { return state_->grid; }

const mesh::TriMesh& IncrementalPolygonizer::reset(const blobtree::Program& program, MpuStats* stats) {
  State& s = *state_;
  s.ready = false;
  s.mesh = detail::polygonizeMpuKeeping(program, s.grid, s.options, stats, s.results);
  s.D = s.options.mpuCells;
  s.mpus = (s.grid.cells + s.D - 1) / s.D;
  s.points = s.grid.points();
  if (s.results.size() != s.mpuCount()) s.results.resize(s.mpuCount());  // an empty grid
  s.scanStarts();
  s.ready = true;
  return s.mesh;
}

const mesh::TriMesh& IncrementalPolygonizer::update(const blobtree::Program& program,
                                                    const blobtree::Region& region,
                                                    IncrementalStats* stats) {
  State& s = *state_;
  if (!s.ready) throw std::logic_error("IncrementalPolygonizer::update before reset");
  const auto tStart = Clock::now();
  IncrementalStats local;
  IncrementalStats& st = stats ? *stats : local;
  st = IncrementalStats{};
  st.mpus = s.mpuCount();
  if (region.empty() || st.mpus == 0) return s.mesh;

  // ---- the MPUs whose box, grown by one cell, meets the region ----
  std::vector<std::uint32_t> dirty;
  std::vector<std::uint8_t> flag(st.mpus, 0);  // 1: re-run, 2: triangles rewritten only
  for (std::size_t m = 0; m < st.mpus; ++m) {
    const glm::ivec3 mi = s.mpuIndex(m);
    const glm::ivec3 lo = mi * s.D - 1, hi = glm::min(mi * s.D + s.D, s.grid.cells) + 1;
    const glm::dvec3 blo(s.grid.point(lo.x, lo.y, lo.z)), bhi(s.grid.point(hi.x, hi.y, hi.z));
    if (blo.x <= region.hi.x && blo.y <= region.hi.y && blo.z <= region.hi.z && bhi.x >= region.lo.x &&
        bhi.y >= region.lo.y && bhi.z >= region.lo.z) {
      dirty.push_back(std::uint32_t(m));
      flag[m] = 1;
    }
  }
  st.mpusRerun = dirty.size();
  if (dirty.empty()) return s.mesh;
  if (dirty.size() * 2 > st.mpus) {  // most of the grid: a full run is as fast and simpler
    reset(program);
    st.full = true;
    st.mpusRerun = st.mpusRewritten = st.mpus;
    st.msTotal = msSince(tStart);
    return s.mesh;
  }

  auto t0 = Clock::now();
  MpuStats polyStats;
  detail::repolygonizeMpus(program, s.grid, s.options, dirty, s.results, &polyStats);
  st.msPolygonize = msSince(t0);

  t0 = Clock::now();
  // Triangles of an MPU below a dirty one name the dirty one's vertices through its ranks.
  for (std::uint32_t m : dirty) {
    const glm::ivec3 mi = s.mpuIndex(m);
    for (int e = 1; e < 8; ++e) {
      const glm::ivec3 n = mi - glm::ivec3(e & 1, (e >> 1) & 1, (e >> 2) & 1);
      if (n.x < 0 || n.y < 0 || n.z < 0) continue;
      std::uint8_t& f = flag[(std::size_t(n.z) * std::size_t(s.mpus.y) + std::size_t(n.y)) * std::size_t(s.mpus.x) + std::size_t(n.x)];
      if (!f) f = 2;
    }
  }
  std::vector<std::uint32_t> rewritten;
  for (std::size_t m = 0; m < st.mpus; ++m)
    if (flag[m]) rewritten.push_back(std::uint32_t(m));
  st.mpusRewritten = rewritten.size();

  // ---- dirty segments in global order ----
  std::vector<DirtySegment> vertexDirty, triangleDirty;
  for (std::uint32_t m : dirty) {
    const glm::ivec3 mi = s.mpuIndex(m), lo = mi * s.D, owned = s.owned(mi);
    const detail::MpuResult* r = s.results[m].get();
    for (int k = 0; k < owned.z; ++k)
      for (int j = 0; j < owned.y; ++j) {
        const std::uint32_t row = std::uint32_t(k * owned.y + j);
        const std::uint32_t count = r ? r->vertexRowStart[row + 1] - r->vertexRowStart[row] : 0u;
        vertexDirty.push_back({s.vertexSegment(lo.z + k, lo.y + j, mi.x), count, m, row});
      }
  }
  for (std::uint32_t m : rewritten) {
    const glm::ivec3 mi = s.mpuIndex(m), lo = mi * s.D, cells = s.cellsOf(mi);
    const detail::MpuResult* r = s.results[m].get();
    for (int k = 0; k < cells.z; ++k)
      for (int j = 0; j < cells.y; ++j) {
        const std::uint32_t row = std::uint32_t(k * cells.y + j);
        const std::uint32_t count = r ? r->triangleRowStart[row + 1] - r->triangleRowStart[row] : 0u;
        triangleDirty.push_back({s.triangleSegment(lo.z + k, lo.y + j, mi.x), count, m, row});
      }
  }
  const auto bySegment = [](const DirtySegment& a, const DirtySegment& b) { return a.segment < b.segment; };
  std::sort(vertexDirty.begin(), vertexDirty.end(), bySegment);
  std::sort(triangleDirty.begin(), triangleDirty.end(), bySegment);

  const Plan vp = plan(s.vertexStarts, vertexDirty);
  const Plan tp = plan(s.triangleStarts, triangleDirty);
  if (vp.newSize >= detail::kDeferred) throw std::length_error("IncrementalPolygonizer: more than 2^31 vertices");
  st.verticesMoved = vp.moved, st.trianglesMoved = tp.moved;

  st.msPlan = msSince(t0);
  auto tPhase = Clock::now();
  mesh::TriMesh& out = s.mesh;
  const int threads = s.options.threads > 0 ? s.options.threads : tbb::info::default_concurrency();
  tbb::task_arena arena(threads);
  const auto moves = [](const Plan& p) {
    return p.newSize != p.oldSize || std::any_of(p.runs.begin(), p.runs.end(), [](const Run& r) { return r.delta != 0; });
  };
  if (moves(vp) || moves(tp)) arena.execute([&] {
    tbb::parallel_invoke(
        [&] { moveRuns(out.positions, vp.runs, vp.oldSize, vp.newSize); },
        [&] { moveRuns(out.edgeKeys, vp.runs, vp.oldSize, vp.newSize); },
        [&] { if (!out.normals.empty() || s.options.normals) moveRuns(out.normals, vp.runs, vp.oldSize, vp.newSize); },
        [&] { if (!out.colours.empty() || s.options.colours) moveRuns(out.colours, vp.runs, vp.oldSize, vp.newSize); },
        [&] { moveRuns(out.triangles, tp.runs, tp.oldSize, tp.newSize); });
  });

  st.msMove = msSince(tPhase);
  tPhase = Clock::now();
  // ---- corners of moved clean triangles: the delta of the vertex run they lie in ----
  // The corners of triangle segment (k, j, a) lie in vertex segments (k, j, a) .. (k + 1, j + 1,
  // a + 1) of the global order; when no dirty vertex segment lies in that window, they all
  // share one delta (usually the case: one add over the whole tail). Otherwise, corner by
  // corner through the vertex runs.
  const auto window = [&](std::size_t tFirst, std::size_t tLast) {
    const std::size_t mx = std::size_t(s.mpus.x), cy = std::size_t(s.grid.cells.y);
    const std::size_t a0 = tFirst % mx, j0 = (tFirst / mx) % cy, k0 = tFirst / (mx * cy);
    const std::size_t a1 = tLast % mx, j1 = (tLast / mx) % cy, k1 = tLast / (mx * cy);
    return std::pair{s.vertexSegment(int(k0), int(j0), int(a0)),
                     s.vertexSegment(int(k1) + 1, int(j1) + 1, int(std::min(a1 + 1, mx - 1)))};
  };
  // before(v): dirty vertex segments before segment v, from a table over the span of the dirty
  // ones (O(1) per lookup; outside the span it is 0 or all of them).
  const std::size_t spanLo = vertexDirty.empty() ? 0 : vertexDirty.front().segment;
  const std::size_t spanHi = vertexDirty.empty() ? 0 : vertexDirty.back().segment + 1;
  std::vector<std::uint32_t> beforeTable(spanHi - spanLo + 1);
  for (std::size_t v = spanLo, i = 0; v <= spanHi; ++v) {
    while (i < vertexDirty.size() && vertexDirty[i].segment < v) ++i;
    beforeTable[v - spanLo] = std::uint32_t(i);
  }
  const auto before = [&](std::size_t v) -> std::size_t {
    if (v <= spanLo) return 0;
    if (v >= spanHi) return vertexDirty.size();
    return beforeTable[v - spanLo];
  };
  // The delta shared by every vertex segment in [lo, hi], or nullopt when a dirty one lies there.
  const auto sharedDelta = [&](std::pair<std::size_t, std::size_t> w) -> std::optional<std::int64_t> {
    const std::size_t b = before(w.first);
    if (before(w.second + 1) != b) return std::nullopt;
    return vp.stretchDelta[b];
  };
  const auto shiftCorners = [&](std::array<std::uint32_t, 3>* tri, std::size_t count, std::int64_t delta) {
    std::uint32_t* v = tri->data();
    const std::uint32_t d = std::uint32_t(delta);  // modular: v + d is v + delta
    for (std::size_t i = 0; i < count * 3; ++i) v[i] += d;
  };
  // Near the edit: the corners of triangle segment (k, j, a) lie in the (clean) vertex segments
  // of rows k..k+1, j..j+1 and columns a..a+1; each corner finds its own among those eight.
  const auto delta = [&](std::size_t vseg) { return vp.stretchDelta[before(vseg)]; };
  const auto shiftCornersBySegment = [&](std::size_t tseg, std::array<std::uint32_t, 3>* tri, std::size_t count) {
    const std::size_t mx = std::size_t(s.mpus.x), cy = std::size_t(s.grid.cells.y);
    const int a = int(tseg % mx), j = int((tseg / mx) % cy), k = int(tseg / (mx * cy));
    Run near[8];
    int n = 0;
    for (int dk = 0; dk < 2; ++dk)
      for (int dj = 0; dj < 2; ++dj)
        for (int da = 0; da < 2 && a + da < s.mpus.x; ++da) {
          const std::size_t vseg = s.vertexSegment(k + dk, j + dj, a + da);
          if (before(vseg + 1) != before(vseg)) continue;  // re-run: no kept triangle names it
          const std::int64_t d = delta(vseg);
          const std::uint32_t count = s.vertexStarts[vseg + 1] - s.vertexStarts[vseg];
          near[n++] = {std::uint32_t(std::int64_t(s.vertexStarts[vseg]) - d), count, d};
        }
    if (std::all_of(near, near + n, [&](const Run& r) { return r.delta == near[0].delta; })) {
      if (near[0].delta) shiftCorners(tri, count, near[0].delta);
      return;
    }
    for (std::size_t t = 0; t < count; ++t)
      for (auto& v : tri[t]) {
        int c = 0;
        while (c < n && v - near[c].from >= near[c].count) ++c;
        if (c == n) throw std::logic_error("IncrementalPolygonizer: a kept triangle names a re-run vertex");
        v = std::uint32_t(std::int64_t(v) + near[c].delta);
      }
  };
  // Triangle runs in segment terms: the clean stretches between dirty triangle segments.
  struct Stretch {
    std::size_t first, last;  // triangle segments
    std::uint32_t from, count;  // new element range
  };
  std::vector<Stretch> stretches;
  {
    std::size_t next = 0;
    for (std::size_t i = 0; i <= triangleDirty.size(); ++i) {
      const std::size_t end = i < triangleDirty.size() ? triangleDirty[i].segment : s.triangleStarts.size() - 1;
      if (end > next) {
        const std::uint32_t from = s.triangleStarts[next], to = s.triangleStarts[end];
        if (to > from) stretches.push_back({next, end - 1, from, to - from});
      }
      if (i < triangleDirty.size()) next = triangleDirty[i].segment + 1;
    }
  }
  if (moves(vp)) {
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, stretches.size(), 1), [&](const auto& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Stretch& t = stretches[i];
          if (const auto d = sharedDelta(window(t.first, t.last))) {
            if (*d) {
              // Long stretches in parallel chunks (the tail after the edit is most of the mesh).
              tbb::parallel_for(tbb::blocked_range<std::size_t>(0, t.count, 1u << 16), [&](const auto& c) {
                shiftCorners(out.triangles.data() + t.from + c.begin(), c.size(), *d);
              });
            }
            continue;
          }
          for (std::size_t seg = t.first; seg <= t.last; ++seg) {  // near the edit: per segment
            const std::uint32_t from = s.triangleStarts[seg], count = s.triangleStarts[seg + 1] - from;
            if (!count) continue;
            if (const auto d = sharedDelta(window(seg, seg))) {
              if (*d) shiftCorners(out.triangles.data() + from, count, *d);
            } else {
              shiftCornersBySegment(seg, out.triangles.data() + from, count);
            }
          }
        }
      });
    });
  }
  st.msShift = msSince(tPhase);
  tPhase = Clock::now();
  // ---- the new segments ----
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertexDirty.size(), 16), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const DirtySegment& d = vertexDirty[i];
        if (!d.count) continue;
        const detail::MpuResult& r = *s.results[d.mpu];
        const std::uint32_t from = r.vertexRowStart[d.row], to = vp.newStarts[i];
        std::copy_n(r.positions.begin() + from, d.count, out.positions.begin() + to);
        std::copy_n(r.keys.begin() + from, d.count, out.edgeKeys.begin() + to);
        if (!r.normals.empty()) std::copy_n(r.normals.begin() + from, d.count, out.normals.begin() + to);
        if (!r.colours.empty()) std::copy_n(r.colours.begin() + from, d.count, out.colours.begin() + to);
      }
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangleDirty.size(), 16), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const DirtySegment& d = triangleDirty[i];
        if (!d.count) continue;
        const detail::MpuResult& r = *s.results[d.mpu];
        // Local vertex id -> global: the owned row it lies in, at that row's new start.
        const auto global = [&](std::uint32_t v) {
          if (v & detail::kDeferred)
            return detail::resolveDeferred(s.mpus, s.points.y, s.results, s.vertexStarts.data(), r, v);
          const auto row = std::size_t(std::upper_bound(r.vertexRowStart.begin(), r.vertexRowStart.end(), v) -
                                       r.vertexRowStart.begin()) - 1;
          const int k = int(row) / r.owned.y, j = int(row) % r.owned.y;
          return s.vertexStarts[s.vertexSegment(r.lo.z + k, r.lo.y + j, r.mpu.x)] + (v - r.vertexRowStart[row]);
        };
        const std::uint32_t from = r.triangleRowStart[d.row], to = tp.newStarts[i];
        for (std::uint32_t n = 0; n < d.count; ++n) {
          auto tri = r.triangles[from + n];
          for (auto& v : tri) v = global(v);
          out.triangles[to + n] = tri;
        }
      }
    });
  });
  st.msWrite = msSince(tPhase);
  st.msSplice = msSince(t0);
  st.msTotal = msSince(tStart);
  return s.mesh;
}

}  // namespace blobvk::cpu
