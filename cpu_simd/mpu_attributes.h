// Internal to blobvk_cpu: the MPU polygonizer's vertex attributes from one analytic-gradient
// pass (structure of arrays) into the mesh's per-vertex Float3 arrays.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <cstddef>

namespace blobvk::cpu::detail {

// out[e] = blobtree::outwardNormal({gx[e], gy[e], gz[e]}) bit for bit: -g / |g|, with
// |g| = sqrt((x*x + y*y) + z*z), and (0, 0, 1) where |g| is not > 0.
void outwardNormals(const float* gx, const float* gy, const float* gz, std::size_t n, mesh::Float3* out);

// out[e] = {r[e], g[e], b[e]}.
void interleave(const float* r, const float* g, const float* b, std::size_t n, mesh::Float3* out);

}  // namespace blobvk::cpu::detail
