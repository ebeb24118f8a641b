#include "blobvk/vk/extract/polygonize.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/slab_polygonizer.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <algorithm>
#include <array>
#include <chrono>

namespace blobvk::vk {
namespace {
double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

mesh::TriMesh polygonize(Device& device, const blobtree::Program& program,
                         const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options,
                         GpuStats* stats) {
  mesh::TriMesh mesh;
  GpuStats s;
  if (grid.cells.x < 1 || grid.cells.y < 1 || grid.cells.z < 1) {
    if (stats) *stats = s;
    return mesh;
  }
  if (options.sparse && !options.tiledVertexPass) return polygonizeSparse(device, program, grid, options, stats);
  if (const std::uint64_t limit = loopIterationLimit(device.info()); limit != ~0ull)
    checkDenseLoopLimit(program, options, limit);
  SlabPolygonizer poly(device, program, grid, options);
  s.fieldTiles = poly.fieldTileCount();
  const auto pts = grid.points();
  const std::uint64_t layer = std::uint64_t(pts.x) * std::uint64_t(pts.y);
  std::uint32_t vertexBase = 0, triangleBase = 0;
  for (std::uint32_t slab = 0; slab < poly.slabCount(); ++slab) {
    const SlabPlan plan = poly.plan(slab);
    auto t0 = std::chrono::steady_clock::now();
    device.run([&](Recorder& rec) {
      poly.recordClassify(rec, slab, vertexBase, triangleBase);
      rec.hostBarrier();
    });
    std::array<std::uint32_t, 7> args{};
    device.download(poly.drawArgs(), args.data(), sizeof(args));
    s.classifySeconds += since(t0);
    s.fieldEvaluations += layer * (plan.cellLayers + 1 + (plan.last ? 0 : 1));
    ++s.bricks;
    const std::uint32_t vertices = args[5] - vertexBase, triangles = args[6] - triangleBase;
    if (vertices || triangles) {
      t0 = std::chrono::steady_clock::now();
      auto make = [&](std::uint64_t bytes) { return device.createBuffer(bytes); };
      Buffer positions = make(std::uint64_t(vertices) * 12), normals = make(options.normals ? vertices * 12ull : 16),
             colours = make(options.colours ? vertices * 12ull : 16), keys = make(vertices * 4ull),
             indices = make(std::uint64_t(triangles) * 12);
      device.run([&](Recorder& rec) {
        poly.recordEmit(rec, slab, vertexBase, {positions, normals, colours, keys, indices, vertices, triangles});
        rec.hostBarrier();
      });
      // The buffers were sized from the counts, so this only fires on a broken invariant; the
      // emit pass then wrote what fitted, and the mesh would have holes.
      if (poly.readOverflow()) throw VulkanError("GPU polygonizer: the emit pass overflowed its output buffers");
      const std::size_t v0 = mesh.positions.size();
      mesh.positions.resize(v0 + vertices);
      device.download(positions, mesh.positions.data() + v0, vertices * 12ull);
      if (options.normals) {
        mesh.normals.resize(v0 + vertices);
        device.download(normals, mesh.normals.data() + v0, vertices * 12ull);
      }
      if (options.colours) {
        mesh.colours.resize(v0 + vertices);
        device.download(colours, mesh.colours.data() + v0, vertices * 12ull);
      }
      std::vector<std::uint32_t> localKeys(vertices);
      device.download(keys, localKeys.data(), vertices * 4ull);
      const std::uint64_t keyBase = std::uint64_t(plan.k0) * layer * 3;
      for (auto k : localKeys) mesh.edgeKeys.push_back(keyBase + k);
      const std::size_t t = mesh.triangles.size();
      mesh.triangles.resize(t + triangles);
      device.download(indices, mesh.triangles.data() + t, triangles * 12ull);
      s.emitSeconds += since(t0);
    }
    vertexBase += vertices;
    triangleBase += triangles;
  }
  s.seconds = s.classifySeconds + s.emitSeconds;
  if (stats) *stats = s;
  return mesh;
}

void polygonizeInto(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                    const GpuPolygonizeOptions& options, mesh::TriMesh& mesh, GpuStats* stats) {
  if (!options.sparse || options.tiledVertexPass || grid.cells.x < 1 || grid.cells.y < 1 || grid.cells.z < 1) {
    mesh = polygonize(device, program, grid, options, stats);  // the dense path builds its own arrays
    return;
  }
  polygonizeSparseInto(device, program, grid, options, mesh, stats);
}

std::uint32_t evaluationsPerVertex(const GpuPolygonizeOptions& options, Traversal ran) {
  // shaders/edge_vertex.glsl: the refinement steps, then the normal samples or the gradient pass.
  const std::uint32_t refinement = std::uint32_t(std::max(options.refineSteps, 0));
  if (ran == Traversal::StackBased) return refinement + (options.normals ? 6u : 0u) + (options.colours ? 1u : 0u);
  return refinement + (options.normals || options.colours ? 1u : 0u);
}

}  // namespace blobvk::vk
