// Internal to the MPU polygonizer: the welded mesh from every MPU's result. A scan over (row, MPU
// column) gives each row of each MPU its place in the output (that order is the global edge-key
// order of vertices and the cell order of triangles), then each MPU's rows are copied there and
// its deferred corners resolved to their owners' vertices.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/cpu_simd/mpu_results.h"
#include "blobvk/mesh/trimesh.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::cpu::detail {

// The scan's answer, kept between meshes so its arrays are reused.
struct MeshPlacement {
  // Per MPU with a result: its first row in vertexBase / triangleBase.
  std::vector<std::size_t> vertexRowAt, triangleRowAt;
  // Per owned point row / cell row of those MPUs: the global index of its first vertex / triangle.
  std::vector<std::uint32_t> vertexBase, triangleBase;
  // Per MPU layer (z index): its first vertex and triangle. Layers own disjoint, consecutive
  // ranges of the output, so they are scanned in parallel.
  std::vector<std::uint64_t> layerVertices, layerTriangles;
  std::vector<std::vector<std::uint32_t>> columns;  // per (MPU row y, layer z): MPUs with a result, by x
};

struct WeldTimes {
  double msScan = 0.0, msCopy = 0.0;
};

// Welds `results` (every MPU of `grid` cut in MPUs of `mpuCells` cells, x fastest; null: no
// surface) into `out`, whose arrays are resized (their capacity reused: a mesh made again into
// the same TriMesh allocates nothing). Parallel in the caller's task arena; the bytes do not
// depend on the thread count. Throws std::length_error past 2^31 vertices or 2^32 triangles.
void weldResults(const blobtree::GridSpec& grid, int mpuCells, const MpuResults& results, bool normals,
                 bool colours, MeshPlacement& placement, mesh::TriMesh& out, WeldTimes* times = nullptr);

}  // namespace blobvk::cpu::detail
