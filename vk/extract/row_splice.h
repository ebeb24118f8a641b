// Splicing a re-run box of the grid into a kept mesh, row by row (host code, no device).
//
// A polygonizer's mesh in global order (vertices by edge key: point z, then y, then x; triangles
// by cell: z, y, x) lays a box of the grid out as rows: the vertices of the box's points on one
// point row (y, z) are one contiguous run of the mesh, and so are the triangles of its cells on
// one cell row. A re-run of the box gives the new rows in the same order (its vertices by key, its
// triangles' corners as edge keys). The splice replaces every row of the box, moves the rest of
// the mesh in place by the change in size of the rows before it, and gives every corner its new
// index: a kept triangle's corner outside the box's rows moves with its run; one inside them (a
// triangle just below or beside the box naming a vertex the box's points own) is found again by
// its edge key among the new rows; a new triangle's corners by key in the spliced vertices.
// That is exact when the box holds every cell and every vertex that changed: the kept triangles'
// cells did not change, so the edges they cross still cross and their vertices keep their keys.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::vk {

// The box in grid points and cells: the points [pointFirst, pointEnd) and the cells
// [cellFirst, cellEnd) per axis (x, y, z) whose vertices and triangles the re-run gave.
struct RowBox {
  std::array<std::uint32_t, 3> pointFirst{}, pointEnd{}, cellFirst{}, cellEnd{};
};

// The elements [from, to) of the spliced mesh whose bytes may differ from the kept mesh's at the
// same index (a copy of the mesh elsewhere, e.g. on the device, needs only these rewritten).
struct ChangedRange {
  std::uint64_t from = 0, to = 0;
};

struct RowSpliceStats {
  std::uint64_t vertexRows = 0, triangleRows = 0;       // rows replaced
  std::uint64_t verticesMoved = 0, trianglesMoved = 0;  // kept elements moved in place
  std::uint64_t cornersByKey = 0;  // kept triangles' corners found again by key
  ChangedRange vertices, triangles;
};

// `mesh`: the kept mesh (sorted edge keys, triangles in cell order) on a grid of `cells` cells.
// `piece`: the box's new vertices in key order (positions, edge keys; normals and colours when the
// mesh has them), its triangles ignored; `cornerKeys`: the box's new triangles in cell order,
// three edge keys each. Throws std::logic_error when the inputs break the contract (a vertex of
// the piece outside the box's rows, a corner whose key no vertex has).
void spliceRows(mesh::TriMesh& mesh, const std::array<std::uint32_t, 3>& cells, const RowBox& box,
                const mesh::TriMesh& piece, const std::vector<std::uint64_t>& cornerKeys,
                RowSpliceStats* stats = nullptr);

}  // namespace blobvk::vk
