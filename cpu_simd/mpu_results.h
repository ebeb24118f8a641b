// Internal to blobvk_cpu: the MPU polygonizer's per-MPU results, exposed so the incremental
// polygonizer (incremental_polygonizer.h) can keep them between meshes and re-run only some MPUs.
// Not a public API.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/mesh/trimesh.h"

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::cpu::detail {

inline constexpr std::uint32_t kDeferred = 1u << 31;  // a triangle corner owned by a neighbour
inline constexpr std::uint8_t kNoRank = 255;

// One MPU's share of the mesh: its owned vertices in edge-key order and its triangles in cell
// order, rows delimited so a scan over (row, MPU column) places them globally.
struct MpuResult {
  glm::ivec3 mpu{0}, lo{0}, pts{0}, owned{0};
  std::vector<mesh::Float3> positions, normals, colours;
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> vertexRowStart;    // per owned point row (k, j), plus the end
  std::vector<std::array<std::uint32_t, 3>> triangles;  // local ids or deferred references
  std::vector<std::uint32_t> triangleRowStart;  // per cell row (k, j), plus the end
  // Rank of each crossing edge inside its point row, for owned points on the low faces
  // (i == 0: faceX[k * owned.y + j]; j == 0: faceY[k * owned.x + i]; k == 0: faceZ[j * owned.x
  // + i]), which is what neighbours below need to number their references to these edges.
  std::vector<std::array<std::uint8_t, 3>> faceX, faceY, faceZ;
};

using MpuResults = std::vector<std::unique_ptr<MpuResult>>;  // per MPU, x fastest; null: no surface

// polygonizeMpu, also handing over every MPU's result.
mesh::TriMesh polygonizeMpuKeeping(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                   const MpuOptions& options, MpuStats* stats, MpuResults& results);

// Re-runs the listed MPUs (indices into `results`, which covers the whole grid) on `program`,
// in parallel, replacing their results. Each MPU is bounded and pruned on its own (no group
// tapes); its result is the one polygonizeMpu would give it, bit for bit.
void repolygonizeMpus(const blobtree::Program& program, const blobtree::GridSpec& grid,
                      const MpuOptions& options, const std::vector<std::uint32_t>& which,
                      MpuResults& results, MpuStats* stats);

// Where a deferred triangle corner of `r` points: the owning MPU (index into results), the
// owner's point row ((k - lo.z) * owned.y + (j - lo.y)) and the rank of the edge in that row.
struct DeferredTarget {
  std::size_t mpu = 0, row = 0;
  std::uint32_t rank = 0;
};
DeferredTarget findDeferred(const glm::ivec3& mpus, const MpuResults& results, const MpuResult& r,
                            std::uint32_t code);

// Global index of the vertex a deferred triangle corner of `r` names, given every MPU's result
// and the scanned vertex row starts ([(k * points.y + j) * mpus.x + column]).
std::uint32_t resolveDeferred(const glm::ivec3& mpus, int pointsY, const MpuResults& results,
                              const std::uint32_t* vertexRows, const MpuResult& r, std::uint32_t code);

}  // namespace blobvk::cpu::detail
