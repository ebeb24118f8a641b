// Tissue regions from the model (the thesis' "material from primitives"): a tet takes the
// material of the primitive whose own field is largest at its centroid.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/tetmesh.h"

#include <cstdint>

namespace blobvk::surgery {

// Index of the primitive whose own field (blobtree::primitiveField) is largest at p; ties go to
// the lowest index. Primitives under warps are looked up at the unwarped point (an
// approximation stated in docs/fem.md, materialFromPrimitive). Throws std::invalid_argument for a Program without
// primitives.
std::uint32_t dominantPrimitive(const blobtree::Program& program, const mesh::Double3& p);

// Sets tets.regions[t] = dominantPrimitive(program, rest centroid of t) for every tet.
void assignTissueRegions(const blobtree::Program& program, mesh::TetMesh& tets);

}  // namespace blobvk::surgery
