// Internal to blobvk_cpu: the MPU polygonizer's triangle phase (case index per cell, triangles
// in cell order, corners owned by a neighbour above deferred to the welding).
#pragma once

#include "blobvk/cpu_simd/mpu_results.h"
#include "blobvk/cpu_simd/row_bits.h"

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::cpu::detail {

// Per-thread scratch of the triangle phase, kept between MPUs.
struct TriangleScratch {
  struct CaseOffsets {
    std::uint8_t corners = 0;      // 3 per triangle
    std::int32_t offset[15] = {};  // corner -> offset in vertexId from the cell's first point
  };
  std::vector<CaseOffsets> caseOffsets;  // per marching-cubes case, for the strides below
  std::size_t caseSy = 0, caseSz = 0;    // the field cache's strides the table was built for
  std::vector<std::array<std::uint32_t, 3>> tris;  // one MPU's triangles, before their copy
};

// r.triangles and r.triangleRowStart of the MPU whose point rows (k, j) of inside flags are
// rows[k * pts.y + j], for the field cache of pts points (x fastest) of which `owned` are the
// MPU's own; vertexId[(point * 3 + axis)] numbers the vertices of its owned crossing edges.
void mpuTriangles(const RowBits* rows, const glm::ivec3& pts, const glm::ivec3& owned,
                  const std::uint32_t* vertexId, TriangleScratch& s, MpuResult& r);

}  // namespace blobvk::cpu::detail
