// IncrementalExtractor (see incremental_extract.h).
//
// Why a box of bricks, spliced row by row: the sparse path orders vertices by global edge key and
// triangles by cell, so a brick's output is spread over its rows, each contiguous with the rows of
// its neighbours along x. The re-run classifies only the box (classifyAndCompact's `only`: the
// bricks outside count as inactive), so the batches number and run the box's active bricks alone
// and give its vertices in key order and its triangles in cell order. The triangles' corners on
// the box's upper faces belong to vertices of bricks outside it, which the run does not load, so
// its triangles come back as edge keys (brick_triangle_keys.comp) and row_splice.cpp finds every
// corner's index in the spliced mesh.
//
// Which neighbours' vertices a brick's triangles use: a cell's corners are the upper edges of its
// 8 corner points, so a brick's triangles name vertices of its own points and of the points on
// its upper faces, owned by its +x, +y, +z neighbours (brick_layout.glsl). Hence a brick kept
// beside or below the box may name vertices the box re-emits: the splice finds them by key (the
// kept cell's edges still cross), and the box need not grow by a brick on its low sides.
#include "blobvk/vk/extract/incremental_extract.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/row_splice.h"
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

}  // namespace

BrickBox bricksReached(const blobtree::GridSpec& grid, const BrickGrid& bricks, const blobtree::Region& region,
                       float normalStep) {
  BrickBox box;
  if (region.empty() || bricks.count() == 0) return box;
  if (region.everything()) return wholeGrid(bricks);
  // In grid units along an axis, with the region at [lo, hi]: a grid point k may change when
  // lo <= k <= hi; the vertex of an edge starting at k (its refinement runs along the edge, its
  // normal samples `s` = normalStep away) when k + 1 + s >= lo and k - s <= hi; a cell starting at
  // k when one of its corners k, k + 1 may change. So every changed vertex or cell starts at k in
  // [ceil(lo - 1 - s), floor(hi + s)]; `e` covers the float rounding of the sample positions.
  // Point k is owned by brick k / B (the grid's last point by the last brick), cell k lies in it.
  const std::int64_t B = std::int64_t(1) << bricks.log2B;
  const std::int64_t n[3] = {bricks.x, bricks.y, bricks.z};
  for (int axis = 0; axis < 3; ++axis) {
    const double o = grid.origin[axis], h = grid.cellSize, c = grid.cells[axis];
    const double e = 1e-3 + 1e-6 * (std::abs(o) + h * c) / h;
    const double s = double(normalStep) / h + e;
    const double lo = std::clamp((region.lo[axis] - o) / h, -4.0 - c, 2.0 * c + 4.0);
    const double hi = std::clamp((region.hi[axis] - o) / h, -4.0 - c, 2.0 * c + 4.0);
    const std::int64_t kMin = std::int64_t(std::ceil(lo - 1.0 - s)), kMax = std::int64_t(std::floor(hi + s));
    if (kMax < 0 || kMin > grid.cells[axis]) return BrickBox{};  // beside the grid: nothing in it changes
    box.first[axis] = std::uint32_t(std::clamp<std::int64_t>(floorDiv(kMin, B), 0, n[axis] - 1));
    box.end[axis] = std::uint32_t(std::clamp<std::int64_t>(floorDiv(kMax, B), 0, n[axis] - 1) + 1);
  }
  return box;
}

struct IncrementalExtractor::State {
  Device& device;
  blobtree::GridSpec grid;
  GpuPolygonizeOptions options;
  std::optional<CodegenOptions> codegen;  // options.codegen points here
  BrickGrid bricks;
  bool ready = false;
  mesh::TriMesh mesh;

  State(Device& d, const blobtree::GridSpec& g, const GpuPolygonizeOptions& o) : device(d), grid(g), options(o) {
    // A row-culling bound belongs to one Program; each edit brings another.
    options.columnSides = nullptr;
    if (!o.sparse || o.tiledVertexPass) {
      throw VulkanError("incremental extraction: needs the sparse extraction (not the dense one, nor tiled vertices)");
    }
    if (o.codegen) {
      codegen = *o.codegen;
      options.codegen = &*codegen;
    }
    bricks = brickGridFor(grid, options.brickCells);
  }

  // Bricks whose rows of points fit the driver's loop limit with this program (loop_limit.h),
  // at each full extraction: the edits re-run bricks of the kept mesh's size.
  void fitBricks(const blobtree::Program& program) {
    bricks = brickGridFor(grid, brickCellsForLoopLimit(device.info(), program, options, options.brickCells));
  }

  // The box's points and cells, whose rows the re-run gives (row_splice.h): a brick owns its
  // points but those on its upper faces, unless it is the grid's last on that axis.
  RowBox rowsOf(const BrickBox& box) const {
    RowBox r;
    const std::uint32_t B = 1u << bricks.log2B, n[3] = {bricks.x, bricks.y, bricks.z};
    for (int axis = 0; axis < 3; ++axis) {
      const std::uint32_t c = std::uint32_t(grid.cells[axis]);
      r.pointFirst[axis] = r.cellFirst[axis] = box.first[axis] * B;
      r.pointEnd[axis] = box.end[axis] == n[axis] ? c + 1 : box.end[axis] * B;
      r.cellEnd[axis] = std::min(box.end[axis] * B, c);
    }
    return r;
  }

  // The evaluator for one run over the active bricks [a0, a1): the session's, or for Auto the cost
  // model's choice for those bricks' points with the build of a specialised kernel counted (each
  // edit's Program needs its own), as polygonizeSparse chooses for a whole grid.
  GpuPolygonizeOptions evaluatorFor(const blobtree::Program& program, const ClassifiedBricks& classified,
                                    std::uint32_t a0, std::uint32_t a1, std::optional<CodegenOptions>& chosen,
                                    GpuStats& s) const {
    GpuPolygonizeOptions resolved = options;
    // An edit re-extracts a box of bricks: kernels for tiles split past maxFieldTiles would not pay.
    resolved.maxFieldTilesForLoopedCode = 0;
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
      const std::vector<std::uint32_t> packed = classified.downloadList(device, a0, a1 - a0);
      evaluated.bricks.reserve(packed.size());
      for (std::uint32_t p : packed) evaluated.bricks.push_back(bricks.unpack(p));
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

  // Classifies the bricks (all, or only `box`'s) and extracts the active ones into `piece`, in the
  // whole-grid batches' order. With `cornerKeys`, the triangles come back there as edge keys.
  void extract(const blobtree::Program& program, const BrickBox* box, mesh::TriMesh& piece,
               std::vector<std::uint64_t>* cornerKeys, IncrementalGpuStats& st) {
    GpuStats& s = st.gpu;
    s.brickCells = 1u << bricks.log2B;
    s.bricks = std::uint32_t(bricks.count());
    auto t0 = Clock::now();
    const ClassifiedBricks classified = classifyAndCompact(device, program, grid, bricks, s, box);
    st.msClassify = msSince(t0);
    t0 = Clock::now();
    const std::vector<SparseBatch> batches = planSparseBatches(
        classified.layerStarts, sparseBatchLimit(device, bricks, options.maxBatchBricks), sparseRangeBricks(device, bricks));
    s.batches = std::uint32_t(batches.size());
    std::uint64_t batchBytes = 0;
    if (!batches.empty()) {
      std::uint32_t maxLoaded = 0;
      for (const SparseBatch& b : batches) maxLoaded = std::max(maxLoaded, b.loadedActive);
      std::optional<CodegenOptions> chosen;
      const GpuPolygonizeOptions resolved =
          evaluatorFor(program, classified, 0, classified.layerStarts.back(), chosen, s);
      SparseBatchRunner runner(device, program, grid, resolved, resolved.traversal, bricks, classified.windows,
                               maxLoaded, s.batches);
      for (const SparseBatch& b : batches) runner.run(b, piece.positions.size(), piece, s, cornerKeys);
      runner.deviceTimes(s);
      batchBytes = runner.sharedBytes() + runner.peakOutputBytes();
    }
    s.deviceBytes = classified.peakBytes(batchBytes);
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
  s.fitBricks(program);
  st.layers = st.layersRerun = s.bricks.z;
  st.bricks = st.bricksRerun = std::uint32_t(s.bricks.count());
  st.box = wholeGrid(s.bricks);
  st.full = true;
  s.ready = false;
  s.mesh = mesh::TriMesh{};
  if (s.grid.cells.x >= 1 && s.grid.cells.y >= 1 && s.grid.cells.z >= 1) s.extract(program, nullptr, s.mesh, nullptr, st);
  st.verticesChanged = {0, s.mesh.positions.size()};
  st.trianglesChanged = {0, s.mesh.triangles.size()};
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
  st.bricks = std::uint32_t(s.bricks.count());
  if (s.grid.cells.x < 1 || s.grid.cells.y < 1 || s.grid.cells.z < 1) return s.mesh;
  const BrickBox box = bricksReached(s.grid, s.bricks, region, s.options.normalStep);
  if (box.empty()) {
    st.msTotal = msSince(tStart);
    return s.mesh;
  }
  if (box.count() == s.bricks.count()) {
    reset(program, &st);
    st.msTotal = msSince(tStart);
    return s.mesh;
  }
  st.box = box;
  st.firstLayer = box.first[2];
  st.layersRerun = box.end[2] - box.first[2];
  st.bricksRerun = std::uint32_t(box.count());

  mesh::TriMesh piece;
  std::vector<std::uint64_t> cornerKeys;
  s.extract(program, &box, piece, &cornerKeys, st);

  const auto tSplice = Clock::now();
  RowSpliceStats rs;
  try {
    spliceRows(s.mesh, {std::uint32_t(s.grid.cells.x), std::uint32_t(s.grid.cells.y), std::uint32_t(s.grid.cells.z)},
               s.rowsOf(box), piece, cornerKeys, &rs);
  } catch (const std::length_error& e) {
    throw VulkanError(e.what());
  }
  st.verticesMoved = rs.verticesMoved;
  st.trianglesMoved = rs.trianglesMoved;
  st.cornersByKey = rs.cornersByKey;
  st.verticesChanged = rs.vertices;
  st.trianglesChanged = rs.triangles;
  st.msSplice = msSince(tSplice);
  st.msTotal = msSince(tStart);
  st.gpu.seconds = st.msTotal / 1000.0;
  return s.mesh;
}

}  // namespace blobvk::vk
