// Layer-by-layer MPU polygonization (see streaming_polygonizer.h).
//
// A layer is computed with repolygonizeMpus (each MPU's result is polygonizeMpu's), then
// compacted: a row table over the layer's own point rows, [(k * points.y + j) * mpus.x + column],
// scanned, places every vertex; corners owned by a neighbour in the same layer are found in the
// owner's row segment by edge key, corners owned by the layer above are left for the join. The
// tables cover one layer (D point rows), never the whole grid: at 4096^3 with D = 16 that is
// 67 MB where the in-memory polygonizer's table of all rows would be 17 GB.
#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "blobvk/cpu_simd/mpu_results.h"

#include <tbb/combinable.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace blobvk::cpu {

std::size_t MeshLayer::bytes() const {
  return (positions.capacity() + normals.capacity() + colours.capacity()) * sizeof(mesh::Float3) +
         keys.capacity() * sizeof(std::uint64_t) + triangles.capacity() * sizeof(triangles[0]) +
         above.capacity() * sizeof(AboveCorner);
}

struct LayerPolygonizer::State {
  const blobtree::Program& program;
  blobtree::GridSpec grid;
  MpuOptions options;
  int D = 0;
  glm::ivec3 mpus{0}, points{0};
  detail::MpuResults results;  // indexed as the whole grid's; only one layer is ever non-null
  MpuStats stats;
  std::unique_ptr<tbb::task_arena> arena;
};

LayerPolygonizer::LayerPolygonizer(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                   const MpuOptions& options)
    : state_(std::make_unique<State>(State{program, grid, options, options.mpuCells, {}, {}, {}, {}, {}})) {
  if (!(grid.cellSize > 0.0f))
    throw std::invalid_argument("polygonizeMpuStreamed: cell size must be positive, got " + std::to_string(grid.cellSize));
  if (grid.cells.x < 0 || grid.cells.y < 0 || grid.cells.z < 0)
    throw std::invalid_argument("polygonizeMpuStreamed: negative cell count");
  if (options.mpuCells < 2 || options.mpuCells > 64)
    throw std::invalid_argument("polygonizeMpuStreamed: mpuCells must be in [2, 64], got " + std::to_string(options.mpuCells));
  if (options.refineSteps < 0) throw std::invalid_argument("polygonizeMpuStreamed: refineSteps must be >= 0");
  if (options.threads < 0) throw std::invalid_argument("polygonizeMpuStreamed: threads must be >= 0");
  State& s = *state_;
  s.options.progress = nullptr;  // reported per layer by the caller
  const bool empty = grid.cells.x == 0 || grid.cells.y == 0 || grid.cells.z == 0;
  s.mpus = empty ? glm::ivec3(0) : (grid.cells + s.D - 1) / s.D;
  s.points = grid.points();
  s.results.resize(std::size_t(s.mpus.x) * std::size_t(s.mpus.y) * std::size_t(s.mpus.z));
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  s.arena = std::make_unique<tbb::task_arena>(threads);
  s.stats.mpuCells = s.D, s.stats.threads = threads;
  s.stats.simd = options.simd.value_or(bestSimdLevel());
}

LayerPolygonizer::~LayerPolygonizer() = default;

int LayerPolygonizer::layerCount() const { return state_->mpus.z; }

const MpuStats& LayerPolygonizer::stats() const { return state_->stats; }

std::size_t LayerPolygonizer::bottomVertices(const MeshLayer& layer) const {
  const State& s = *state_;
  const std::uint64_t planeEnd = s.grid.edgeKey(0, 0, layer.z * s.D + 1, 0);  // first key of the next plane
  return std::size_t(std::lower_bound(layer.keys.begin(), layer.keys.end(), planeEnd) - layer.keys.begin());
}

namespace {

std::uint64_t exclusiveScan(std::vector<std::uint32_t>& counts) {
  std::uint64_t sum = 0;
  for (auto& c : counts) {
    const std::uint32_t n = c;
    c = std::uint32_t(sum);
    sum += n;
  }
  return sum;
}

}  // namespace

MeshLayer LayerPolygonizer::layer(int z) {
  State& s = *state_;
  if (z < 0 || z >= s.mpus.z) throw std::out_of_range("LayerPolygonizer: layer " + std::to_string(z) + " out of range");
  const std::size_t perLayer = std::size_t(s.mpus.x) * std::size_t(s.mpus.y);
  std::vector<std::uint32_t> which(perLayer);
  for (std::size_t i = 0; i < perLayer; ++i) which[i] = std::uint32_t(std::size_t(z) * perLayer + i);
  detail::repolygonizeMpus(s.program, s.grid, s.options, which, s.results, &s.stats);
  s.stats.pointEvaluations = s.stats.gridEvaluations + s.stats.edgeEvaluations + s.stats.attributeEvaluations;

  const int D = s.D, zLo = z * D;
  const bool top = z == s.mpus.z - 1;
  const int pointRows = top ? s.points.z - zLo : D;          // point rows this layer owns
  const int cellRows = std::min(D, s.grid.cells.z - zLo);    // cell rows it holds
  const std::size_t py = std::size_t(s.points.y), cy = std::size_t(s.grid.cells.y), mx = std::size_t(s.mpus.x);
  std::vector<std::uint32_t> vertexRows(std::size_t(pointRows) * py * mx, 0u);
  std::vector<std::uint32_t> triangleRows(std::size_t(cellRows) * cy * mx, 0u);
  const auto result = [&](std::size_t i) { return s.results[std::size_t(z) * perLayer + i].get(); };
  for (std::size_t i = 0; i < perLayer; ++i) {
    const detail::MpuResult* r = result(i);
    if (!r) continue;
    for (int k = 0; k < r->owned.z; ++k)
      for (int j = 0; j < r->owned.y; ++j) {
        const std::size_t row = std::size_t(k) * std::size_t(r->owned.y) + std::size_t(j);
        vertexRows[(std::size_t(k) * py + std::size_t(r->lo.y + j)) * mx + std::size_t(r->mpu.x)] =
            r->vertexRowStart[row + 1] - r->vertexRowStart[row];
      }
    const int ncy = r->pts.y - 1, ncz = r->pts.z - 1;
    for (int k = 0; k < ncz; ++k)
      for (int j = 0; j < ncy; ++j) {
        const std::size_t row = std::size_t(k * ncy + j);
        triangleRows[(std::size_t(k) * cy + std::size_t(r->lo.y + j)) * mx + std::size_t(r->mpu.x)] =
            r->triangleRowStart[row + 1] - r->triangleRowStart[row];
      }
  }
  const std::uint64_t nv = exclusiveScan(vertexRows), nt = exclusiveScan(triangleRows);
  if (nv >= std::uint64_t(detail::kDeferred) || nt >= std::uint64_t(detail::kDeferred))
    throw std::length_error("polygonizeMpuStreamed: more than 2^31 vertices or triangles in one layer");

  MeshLayer out;
  out.z = z;
  out.positions.resize(nv);
  out.keys.resize(nv);
  if (s.options.normals) out.normals.resize(nv);
  if (s.options.colours) out.colours.resize(nv);
  out.triangles.resize(nt);

  // Vertices to their places.
  s.arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, perLayer, 1), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const detail::MpuResult* r = result(i);
        if (!r) continue;
        for (int k = 0; k < r->owned.z; ++k)
          for (int j = 0; j < r->owned.y; ++j) {
            const std::size_t row = std::size_t(k) * std::size_t(r->owned.y) + std::size_t(j);
            const std::uint32_t begin = r->vertexRowStart[row], end = r->vertexRowStart[row + 1];
            const std::uint32_t base = vertexRows[(std::size_t(k) * py + std::size_t(r->lo.y + j)) * mx + std::size_t(r->mpu.x)];
            std::copy(r->positions.begin() + begin, r->positions.begin() + end, out.positions.begin() + base);
            std::copy(r->keys.begin() + begin, r->keys.begin() + end, out.keys.begin() + base);
            if (!r->normals.empty()) std::copy(r->normals.begin() + begin, r->normals.begin() + end, out.normals.begin() + base);
            if (!r->colours.empty()) std::copy(r->colours.begin() + begin, r->colours.begin() + end, out.colours.begin() + base);
          }
      }
    });
  });

  // Triangles to their places, corners as layer indices (or left for the join).
  tbb::combinable<std::vector<MeshLayer::AboveCorner>> above;
  tbb::combinable<std::vector<std::uint32_t>> scratch;
  s.arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, perLayer, 1), [&](const auto& range) {
      std::vector<std::uint32_t>& localToLayer = scratch.local();
      std::vector<MeshLayer::AboveCorner>& mine = above.local();
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const detail::MpuResult* r = result(i);
        if (!r) continue;
        localToLayer.resize(r->positions.size());
        for (int k = 0; k < r->owned.z; ++k)
          for (int j = 0; j < r->owned.y; ++j) {
            const std::size_t row = std::size_t(k) * std::size_t(r->owned.y) + std::size_t(j);
            const std::uint32_t begin = r->vertexRowStart[row], end = r->vertexRowStart[row + 1];
            const std::uint32_t base = vertexRows[(std::size_t(k) * py + std::size_t(r->lo.y + j)) * mx + std::size_t(r->mpu.x)];
            for (std::uint32_t v = begin; v < end; ++v) localToLayer[v] = base + (v - begin);
          }
        // A corner owned by a neighbour: its edge key, then its owner's row segment (or the
        // layer above's, resolved at the join).
        const auto deferred = [&](std::uint32_t code, std::uint64_t slot) -> std::uint32_t {
          const int q[3] = {int(code & 127u), int((code >> 7) & 127u), int((code >> 14) & 127u)};
          const int axis = int((code >> 21) & 3u);
          const glm::ivec3 g = r->lo + glm::ivec3(q[0], q[1], q[2]);
          const std::uint64_t key = s.grid.edgeKey(g.x, g.y, g.z, axis);
          if (g.z - zLo >= pointRows) {
            mine.push_back({slot, key});
            return 0u;
          }
          const int ownerX = r->mpu.x + (q[0] >= r->owned.x ? 1 : 0);
          const std::size_t row = (std::size_t(g.z - zLo) * py + std::size_t(g.y)) * mx + std::size_t(ownerX);
          const std::uint32_t begin = vertexRows[row];
          const std::uint32_t end = row + 1 < vertexRows.size() ? vertexRows[row + 1] : std::uint32_t(nv);
          const auto it = std::lower_bound(out.keys.begin() + begin, out.keys.begin() + end, key);
          if (it == out.keys.begin() + end || *it != key)
            throw std::logic_error("polygonizeMpuStreamed: a triangle refers to an edge its owner has no vertex for");
          return std::uint32_t(it - out.keys.begin());
        };
        const int ncy = r->pts.y - 1, ncz = r->pts.z - 1;
        for (int k = 0; k < ncz; ++k)
          for (int j = 0; j < ncy; ++j) {
            const std::size_t row = std::size_t(k * ncy + j);
            const std::uint32_t begin = r->triangleRowStart[row], end = r->triangleRowStart[row + 1];
            const std::uint32_t base = triangleRows[(std::size_t(k) * cy + std::size_t(r->lo.y + j)) * mx + std::size_t(r->mpu.x)];
            for (std::uint32_t t = begin; t < end; ++t) {
              const std::uint64_t at = std::uint64_t(base) + (t - begin);
              std::array<std::uint32_t, 3> tri = r->triangles[t];
              for (int c = 0; c < 3; ++c) {
                std::uint32_t& v = tri[std::size_t(c)];
                v = (v & detail::kDeferred) ? deferred(v, at * 3 + std::uint64_t(c)) : localToLayer[v];
              }
              out.triangles[at] = tri;
            }
          }
      }
    });
  });
  above.combine_each([&](const std::vector<MeshLayer::AboveCorner>& v) { out.above.insert(out.above.end(), v.begin(), v.end()); });
  // Combination order follows the threads; the join does not depend on it, but a sorted list
  // makes the layer itself the same bytes for any thread count.
  std::sort(out.above.begin(), out.above.end(), [](const auto& a, const auto& b) { return a.slot < b.slot; });
  for (std::size_t i = 0; i < perLayer; ++i) s.results[std::size_t(z) * perLayer + i].reset();
  s.stats.vertices += nv, s.stats.triangles += nt;
  return out;
}

// ---- join ----------------------------------------------------------------------------------

LayerJoiner::LayerJoiner(mesh::MeshSink& sink) : sink_(sink) {}
LayerJoiner::~LayerJoiner() = default;

void LayerJoiner::push(MeshLayer layer) {
  const std::uint64_t first = nextVertex_;
  if (first + layer.positions.size() >= std::uint64_t(detail::kDeferred))
    throw std::length_error("polygonizeMpuStreamed: more than 2^31 vertices (the mesh's and PLY's index limit)");
  peakBytes_ = std::max(peakBytes_, layer.bytes() + (pending_ ? pending_->bytes() : 0));
  sink_.vertices(layer.positions, layer.normals, layer.colours);
  nextVertex_ = first + layer.positions.size();
  if (pending_) emitPending(&layer, first);
  pending_ = std::move(layer);
  pendingFirst_ = first;
}

void LayerJoiner::finish() {
  if (pending_) emitPending(nullptr, 0);
  pending_.reset();
}

void LayerJoiner::emitPending(const MeshLayer* above, std::uint64_t aboveFirst) {
  MeshLayer& p = *pending_;
  const std::uint32_t first = std::uint32_t(pendingFirst_);
  for (auto& t : p.triangles)
    for (auto& v : t) v += first;
  for (const MeshLayer::AboveCorner& c : p.above) {
    if (!above) throw std::logic_error("polygonizeMpuStreamed: the top layer refers to a layer above it");
    const auto it = std::lower_bound(above->keys.begin(), above->keys.end(), c.key);
    if (it == above->keys.end() || *it != c.key)
      throw std::logic_error("polygonizeMpuStreamed: a triangle refers to an edge the layer above has no vertex for");
    p.triangles[c.slot / 3][c.slot % 3] = std::uint32_t(aboveFirst + std::uint64_t(it - above->keys.begin()));
  }
  mesh::VertexWindow window;
  window.first = pendingFirst_;
  window.a = p.positions;
  if (above) window.b = above->positions;
  sink_.triangles(p.triangles, window);
  triangles_ += p.triangles.size();
}

mesh::TriMesh polygonizeLayerRange(LayerPolygonizer& layers, int first, int end) {
  if (first < 0 || end > layers.layerCount() || first > end)
    throw std::invalid_argument("polygonizeLayerRange: layers [" + std::to_string(first) + ", " + std::to_string(end) +
                                ") are outside the grid's " + std::to_string(layers.layerCount()));
  std::vector<MeshLayer> own;
  std::vector<std::uint64_t> firsts;  // each layer's first vertex in the piece, then the count
  std::uint64_t count = 0;
  for (int z = first; z < end; ++z) {
    own.push_back(layers.layer(z));
    firsts.push_back(count);
    count += own.back().positions.size();
  }
  firsts.push_back(count);
  if (count > 0xffffffffull) throw std::length_error("polygonizeLayerRange: more than 2^32 vertices in one piece");
  std::optional<MeshLayer> next;
  if (!own.empty() && !own.back().above.empty() && end < layers.layerCount()) next = layers.layer(end);

  mesh::TriMesh piece;
  for (const MeshLayer& l : own) {
    piece.positions.insert(piece.positions.end(), l.positions.begin(), l.positions.end());
    piece.normals.insert(piece.normals.end(), l.normals.begin(), l.normals.end());
    piece.colours.insert(piece.colours.end(), l.colours.begin(), l.colours.end());
    piece.edgeKeys.insert(piece.edgeKeys.end(), l.keys.begin(), l.keys.end());
  }
  for (std::size_t i = 0; i < own.size(); ++i) {
    const MeshLayer& l = own[i];
    const std::size_t t0 = piece.triangles.size();
    const std::uint32_t base = std::uint32_t(firsts[i]);
    for (auto t : l.triangles) piece.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    const MeshLayer* above = i + 1 < own.size() ? &own[i + 1] : next ? &*next : nullptr;
    for (const MeshLayer::AboveCorner& c : l.above) {
      if (!above) throw std::logic_error("polygonizeLayerRange: the top layer refers to a layer above it");
      const auto it = std::lower_bound(above->keys.begin(), above->keys.end(), c.key);
      if (it == above->keys.end() || *it != c.key)
        throw std::logic_error("polygonizeLayerRange: a triangle refers to an edge the layer above has no vertex for");
      piece.triangles[t0 + c.slot / 3][c.slot % 3] = std::uint32_t(firsts[i + 1] + std::uint64_t(it - above->keys.begin()));
    }
  }
  return piece;
}

MpuStats polygonizeMpuStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                               const MpuOptions& options, mesh::MeshSink& sink) {
  const auto start = std::chrono::steady_clock::now();
  LayerPolygonizer layers(program, grid, options);
  LayerJoiner join(sink);
  const int n = layers.layerCount();
  for (int z = 0; z < n; ++z) {
    join.push(layers.layer(z));
    if (options.progress) options.progress(std::size_t(z + 1), std::size_t(n));
  }
  join.finish();
  MpuStats stats = layers.stats();
  stats.fvept = stats.triangles ? double(stats.pointEvaluations) / double(stats.triangles) : 0.0;
  stats.msTotal = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace blobvk::cpu
