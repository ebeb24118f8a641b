// Numbering a tetrahedral mesh so that tets and nodes near each other in space are near each
// other in memory. TetGen numbers its tets in the order of its memory pool and its Steiner
// points in insertion order, so a cut's candidate tets and their nodes, and a row of the FEM
// matrix, touch pages all over the mesh; sorted along a Z-order curve they touch few.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <cstddef>

namespace blobvk::fem {

// Renumbers `mesh` in Z-order of the rest positions: the tets by their centroids, the nodes from
// `keepNodes` on by their positions (nodes below it keep their numbers: TetGen's input points,
// which a render surface shares, fem/tetgen_mesher.h). Ties keep the old order, so the result
// is deterministic. Tet node order (orientation) and the regions go along with each tet; the
// boundary faces are found again (sorted, as findBoundaryFaces).
void orderForLocality(mesh::TetMesh& mesh, std::size_t keepNodes);

}  // namespace blobvk::fem
