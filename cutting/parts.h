// After a cut: the pieces the mesh fell into and its boundary surface (crack faces included).
#pragma once

#include "blobvk/cutting/topology.h"
#include "blobvk/mesh/trimesh.h"

#include <cstdint>
#include <vector>

namespace blobvk::cutting {

// Live tet slots grouped by face connectivity, largest part first. A flap cut free is a part.
std::vector<std::vector<std::uint32_t>> disjointParts(const CutTopology& topology);

// Faces used by one tet, outward, over the referenced nodes only (float, current positions).
mesh::TriMesh boundarySurface(const CutTopology& topology);

}  // namespace blobvk::cutting
