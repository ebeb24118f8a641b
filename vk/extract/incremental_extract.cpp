// IncrementalExtractor (see incremental_extract.h).
//
// Why whole brick layers: within a layer the sparse path orders vertices by global edge key and
// triangles by cell, interleaving the layer's bricks row by row, so the smallest contiguous
// piece of the output that one batch produces is a run of whole layers. A batch emitting layers
// [first, end) loads layer `end` too (the triangles of its last layer name vertices there), so
// given the vertex base of layer `first` in the kept mesh, its triangles come out with their
// final indices.
//
// Why the bricks are classified again over the whole grid: the batch runner reads the active
// bricks' global numbering (the scanned flags) to find a brick's neighbours, and
// classifyAndCompact covers the grid. Narrowing it to the re-run layers needs brick_classify to
// take a first layer; it is a sixth of an edit of tower_L6P8I4 at 256 (docs/performance.md).
#include "blobvk/vk/extract/incremental_extract.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/extract/sparse_batches.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

namespace blobvk::vk {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::int64_t floorDiv(std::int64_t a, std::int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// Replaces v[from, to) by `with`, moving the tail in place; returns the elements moved.
template <class T>
std::uint64_t replaceRange(std::vector<T>& v, std::size_t from, std::size_t to, const std::vector<T>& with) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::size_t tail = v.size() - to, newTo = from + with.size();
  if (newTo > to) v.resize(v.size() + (newTo - to));
  if (tail && newTo != to) std::memmove(v.data() + newTo, v.data() + to, tail * sizeof(T));
  if (newTo < to) v.resize(v.size() - (to - newTo));
  if (!with.empty()) std::memcpy(v.data() + from, with.data(), with.size() * sizeof(T));
  return newTo != to ? tail : 0;
}

}  // namespace

LayerRange layersReached(const blobtree::GridSpec& grid, std::uint32_t brickCells, std::uint32_t layers,
                         const blobtree::Region& region, float normalStep) {
  LayerRange r;
  if (region.empty() || layers == 0) return r;
  if (region.everything()) return {0, layers};
  // In grid units along an axis, with the region at [lo, hi]: a grid point k may change when
  // lo <= k <= hi; the vertex of an edge starting at k (its refinement runs along the edge, its
  // normal samples `s` = normalStep away) when k + 1 + s >= lo and k - s <= hi; a cell starting at
  // k when its corner k + 1 or k may change. So every changed vertex or cell starts at k in
  // [ceil(lo - 1 - s), floor(hi + s)]; `e` covers the float rounding of the sample positions.
  const auto reach = [&](int axis) {
    const double o = grid.origin[axis], h = grid.cellSize, n = grid.cells[axis];
    const double e = 1e-3 + 1e-6 * (std::abs(o) + h * n) / h;
    const double s = double(normalStep) / h + e;
    const double lo = std::clamp((region.lo[axis] - o) / h, -4.0 - n, 2.0 * n + 4.0);
    const double hi = std::clamp((region.hi[axis] - o) / h, -4.0 - n, 2.0 * n + 4.0);
    return std::pair<std::int64_t, std::int64_t>{std::int64_t(std::ceil(lo - 1.0 - s)), std::int64_t(std::floor(hi + s))};
  };
  for (int axis = 0; axis < 2; ++axis) {  // a region beside the grid changes nothing in it
    const auto [kMin, kMax] = reach(axis);
    if (kMax < 0 || kMin > grid.cells[axis]) return r;
  }
  const auto [kMin, kMax] = reach(2);
  // Layers before `first` keep their triangles and the numbers of the vertices they name (those
  // of point layer first * B, the first of layer `first`) when every change starts after that
  // point layer: first * B < kMin. Layers from `end` on keep everything when kMax < end * B.
  const std::int64_t B = brickCells, L = layers;
  r.first = std::uint32_t(std::clamp<std::int64_t>(floorDiv(kMin - 1, B), 0, L));
  r.end = std::uint32_t(std::clamp<std::int64_t>(floorDiv(kMax, B) + 1, 0, L));
  if (r.end < r.first) r.end = r.first;
  return r;
}

struct IncrementalExtractor::State {
  Device& device;
  blobtree::GridSpec grid;
  GpuPolygonizeOptions options;
  std::optional<CodegenOptions> codegen;  // options.codegen points here
  BrickGrid bricks;
  bool ready = false;
  mesh::TriMesh mesh;
  // First vertex and first triangle of each brick layer, plus the totals (layers + 1 entries).
  std::vector<std::uint32_t> vertexStarts, triangleStarts;

  State(Device& d, const blobtree::GridSpec& g, const GpuPolygonizeOptions& o) : device(d), grid(g), options(o) {
    if (!o.sparse || o.tiledVertexPass) {
      throw VulkanError("incremental extraction: needs the sparse extraction (not the dense one, nor tiled vertices)");
    }
    if (o.codegen) {
      codegen = *o.codegen;
      options.codegen = &*codegen;
    }
    bricks = brickGridFor(grid, options.brickCells);
  }

  std::uint32_t layerOfPoint(std::uint64_t k) const {
    return std::min<std::uint32_t>(std::uint32_t(k >> bricks.log2B), bricks.z - 1);
  }
  // The point layer (z) of a vertex, from its edge key (grid.edgeKey).
  std::uint64_t pointZ(std::uint64_t key) const {
    const auto p = grid.points();
    return key / 3 / (std::uint64_t(p.x) * std::uint64_t(p.y));
  }

  // Per-layer starts from the mesh itself: vertices by their edge key's point layer; triangles
  // (in cell order) by their cell's layer. A triangle's cell z is the least point layer of its
  // corners: its z edges start there, and a marching-cubes triangle never has all three corners
  // on the cell's top face (it would lie in that face; tests/vk checks the table).
  void scanStarts() {
    const std::uint32_t layers = bricks.z;
    vertexStarts.assign(layers + 1, 0);
    triangleStarts.assign(layers + 1, 0);
    const auto& keys = mesh.edgeKeys;
    const auto& tris = mesh.triangles;
    const std::uint64_t B = 1ull << bricks.log2B;
    auto cellZ = [&](const std::array<std::uint32_t, 3>& t) {
      return std::min({pointZ(keys[t[0]]), pointZ(keys[t[1]]), pointZ(keys[t[2]])});
    };
    for (std::uint32_t z = 1; z < layers; ++z) {
      const std::uint64_t k = z * B;
      vertexStarts[z] = std::uint32_t(std::partition_point(keys.begin(), keys.end(), [&](std::uint64_t key) {
                                        return pointZ(key) < k;
                                      }) - keys.begin());
      triangleStarts[z] = std::uint32_t(std::partition_point(tris.begin(), tris.end(), [&](const auto& t) {
                                          return cellZ(t) < k;
                                        }) - tris.begin());
    }
    vertexStarts[layers] = std::uint32_t(keys.size());
    triangleStarts[layers] = std::uint32_t(tris.size());
  }

  // The evaluator for one run over the active bricks [a0, a1): the session's, or for Auto the cost
  // model's choice for those bricks' points with the build of a specialised kernel counted (each
  // edit's Program needs its own), as polygonizeSparse chooses for a whole grid.
  GpuPolygonizeOptions evaluatorFor(const blobtree::Program& program, const ClassifiedBricks& classified,
                                    std::uint32_t a0, std::uint32_t a1, std::optional<CodegenOptions>& chosen,
                                    GpuStats& s) const {
    GpuPolygonizeOptions resolved = options;
    if (options.traversal != Traversal::Auto) {
      s.traversal = options.traversal;
      return resolved;
    }
    EvaluatorJob job;
    job.vertexPass = true;
    job.refineSteps = options.refineSteps;
    job.tiling.maxTiles = 1;
    EvaluatedBricks evaluated;
    evaluated.cells = 1u << bricks.log2B;
    if (device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU && a1 > a0) {  // elsewhere the choice ignores them
      std::vector<std::uint32_t> packed(a1 - a0);
      device.download(classified.list, packed.data(), packed.size() * 4, 4ull * a0);
      evaluated.bricks.reserve(packed.size());
      for (std::uint32_t p : packed) evaluated.bricks.push_back({p & 1023u, (p >> 10) & 1023u, (p >> 20) & 1023u});
    }
    job.evaluated = &evaluated;
    chosen = codegen ? *codegen : defaultCodegenOptions(device);
    const EvaluatorEstimate e = chooseEvaluator(device, program, grid, job, *chosen).chosen;
    chosen->gradient = e.vertexGradient;
    resolved.traversal = e.traversal;
    resolved.codegen = &*chosen;
    s.traversal = e.traversal;
    s.vertexGradient = e.traversal == Traversal::Specialised && e.vertexGradient;
    return resolved;
  }

  // Classifies the grid and extracts layers [first, end) into `piece`, its triangles numbered
  // from `vertexBase`.
  void extract(const blobtree::Program& program, std::uint32_t first, std::uint32_t end, std::uint32_t vertexBase,
               mesh::TriMesh& piece, IncrementalGpuStats& st) {
    GpuStats& s = st.gpu;
    s.brickCells = 1u << bricks.log2B;
    s.bricks = std::uint32_t(bricks.count());
    auto t0 = Clock::now();
    const ClassifiedBricks classified = classifyAndCompact(device, program, grid, bricks, s);
    st.msClassify = msSince(t0);
    t0 = Clock::now();
    const std::vector<std::uint32_t>& starts = classified.layerStarts;
    const std::uint64_t range = sparseRangeBricks(device, bricks);
    std::vector<SparseBatch> batches =
        planSparseBatches(std::span(starts).subspan(first, end - first + 1),
                          sparseBatchLimit(device, bricks, options.maxBatchBricks), range);
    // The plan saw layers [first, end) only; the last batch also loads layer `end` (whose vertex
    // numbers its last layer's triangles use), as a batch inside a whole-grid plan would.
    if (!batches.empty()) {
      SparseBatch& last = batches.back();
      last.loadedActive = starts[std::min<std::uint32_t>(end + 1, bricks.z)] - last.activeBase;
      if (last.loadedActive > range) {
        throw VulkanError("GPU polygonizer: two brick layers hold " + std::to_string(last.loadedActive) +
                          " active bricks, over the " + std::to_string(range) +
                          " one storage buffer can hold (maxStorageBufferRange): use a smaller grid or bricks");
      }
    }
    s.activeBricks = starts[end] - starts[first];
    s.batches = std::uint32_t(batches.size());
    std::uint64_t bytes = classified.bytes;
    if (!batches.empty()) {
      std::uint32_t maxLoaded = 0;
      for (const SparseBatch& b : batches) maxLoaded = std::max(maxLoaded, b.loadedActive);
      std::optional<CodegenOptions> chosen;
      const GpuPolygonizeOptions resolved = evaluatorFor(
          program, classified, starts[first], starts[std::min<std::uint32_t>(end + 1, bricks.z)], chosen, s);
      SparseBatchRunner runner(device, program, grid, resolved, resolved.traversal, bricks, classified.scan,
                               classified.list, maxLoaded, s.batches);
      for (const SparseBatch& b : batches) runner.run(b, vertexBase + piece.positions.size(), piece, s);
      runner.deviceTimes(s);
      bytes += runner.sharedBytes() + runner.peakOutputBytes();
    }
    s.deviceBytes = bytes;
    st.msExtract = msSince(t0);
  }
};

IncrementalExtractor::IncrementalExtractor(Device& device, const blobtree::GridSpec& grid,
                                           const GpuPolygonizeOptions& options)
    : state_(std::make_unique<State>(device, grid, options)) {}

IncrementalExtractor::~IncrementalExtractor() = default;

const mesh::TriMesh& IncrementalExtractor::mesh() const { return state_->mesh; }
const blobtree::GridSpec& IncrementalExtractor::grid() const { return state_->grid; }
const GpuPolygonizeOptions& IncrementalExtractor::options() const { return state_->options; }

const mesh::TriMesh& IncrementalExtractor::reset(const blobtree::Program& program, IncrementalGpuStats* stats) {
  State& s = *state_;
  const auto tStart = Clock::now();
  IncrementalGpuStats local;
  IncrementalGpuStats& st = stats ? *stats : local;
  st = IncrementalGpuStats{};
  st.layers = s.bricks.z;
  st.layersRerun = s.bricks.z;
  st.full = true;
  s.ready = false;
  s.mesh = mesh::TriMesh{};
  if (s.grid.cells.x >= 1 && s.grid.cells.y >= 1 && s.grid.cells.z >= 1) {
    s.extract(program, 0, s.bricks.z, 0, s.mesh, st);
  }
  auto t0 = Clock::now();
  s.scanStarts();
  st.msSplice = msSince(t0);
  s.ready = true;
  st.msTotal = msSince(tStart);
  st.gpu.seconds = st.msTotal / 1000.0;
  return s.mesh;
}

const mesh::TriMesh& IncrementalExtractor::update(const blobtree::Program& program, const blobtree::Region& region,
                                                  IncrementalGpuStats* stats) {
  State& s = *state_;
  if (!s.ready) throw std::logic_error("IncrementalExtractor::update before reset");
  const auto tStart = Clock::now();
  IncrementalGpuStats local;
  IncrementalGpuStats& st = stats ? *stats : local;
  st = IncrementalGpuStats{};
  st.layers = s.bricks.z;
  if (s.grid.cells.x < 1 || s.grid.cells.y < 1 || s.grid.cells.z < 1) return s.mesh;
  const LayerRange r = layersReached(s.grid, 1u << s.bricks.log2B, s.bricks.z, region, s.options.normalStep);
  if (r.first == r.end) {
    st.msTotal = msSince(tStart);
    return s.mesh;
  }
  if (r.first == 0 && r.end == s.bricks.z) {
    reset(program, &st);
    st.msTotal = msSince(tStart);
    return s.mesh;
  }
  st.firstLayer = r.first;
  st.layersRerun = r.end - r.first;

  mesh::TriMesh piece;
  const std::uint32_t v0 = s.vertexStarts[r.first], v1 = s.vertexStarts[r.end];
  const std::uint32_t t0 = s.triangleStarts[r.first], t1 = s.triangleStarts[r.end];
  s.extract(program, r.first, r.end, v0, piece, st);

  const auto tSplice = Clock::now();
  mesh::TriMesh& m = s.mesh;
  if (std::uint64_t(m.positions.size()) - (v1 - v0) + piece.positions.size() > 0xffffffffull) {
    throw VulkanError("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
  }
  st.verticesMoved = replaceRange(m.positions, v0, v1, piece.positions);
  replaceRange(m.edgeKeys, v0, v1, piece.edgeKeys);
  if (s.options.normals) replaceRange(m.normals, v0, v1, piece.normals);
  if (s.options.colours) replaceRange(m.colours, v0, v1, piece.colours);
  st.trianglesMoved = replaceRange(m.triangles, t0, t1, piece.triangles);
  // Triangles after the piece name vertices after it, which moved by the change in count.
  const std::uint32_t delta = std::uint32_t(piece.positions.size()) - (v1 - v0);  // modulo 2^32
  if (delta) {
    for (std::size_t t = t0 + piece.triangles.size(); t < m.triangles.size(); ++t)
      for (std::uint32_t& v : m.triangles[t]) v += delta;
  }
  s.scanStarts();
  st.msSplice = msSince(tSplice);
  st.msTotal = msSince(tStart);
  st.gpu.seconds = st.msTotal / 1000.0;
  return s.mesh;
}

}  // namespace blobvk::vk
