// The marching-cubes case table as the extraction kernels read it (shaders/brick_*.comp,
// slab kernels): 20 uint32 per configuration, the triangle count then 18 edge ids.
#pragma once

#include <cstdint>
#include <vector>

namespace blobvk::vk {

// Built once per process from mesh::marchingCubesCases().
const std::vector<std::uint32_t>& packedCaseTable();

}  // namespace blobvk::vk
