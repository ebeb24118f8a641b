// The marching-cubes case table as the extraction kernels read it (shaders/brick_*.comp,
// slab kernels): 20 uint32 per configuration, the triangle count then 18 edge ids; or packed
// in a uniform buffer (brick kernels).
#pragma once

#include <cstdint>
#include <vector>

namespace blobvk::vk {

// Built once per process from mesh::marchingCubesCases().
const std::vector<std::uint32_t>& packedCaseTable();

// The sparse kernels' uniform-buffer form (shaders/brick_layout.glsl): 4 words per configuration,
// the triangle count, then the 15 edge ids at 4 bits each (edges 0..7, then 8..14), then 0.
const std::vector<std::uint32_t>& caseTableUniform();

}  // namespace blobvk::vk
