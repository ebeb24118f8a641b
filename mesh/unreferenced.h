// Dropping the vertices no triangle uses: a tet-boundary surface (fem::boundarySurface) keeps
// every node of its tet mesh, interior ones included, so that its vertex i is node i; a file
// written for a viewer or a downstream tool should hold the surface's own vertices only.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <cstddef>

namespace blobvk::mesh {

// Removes the vertices no triangle references, with their normals, colours and edge keys (each
// array that has one entry per vertex), keeping the others in their order and renumbering the
// triangles. Returns how many were removed. Throws std::out_of_range on a triangle index past
// the last vertex.
std::size_t dropUnreferencedVertices(TriMesh& mesh);

}  // namespace blobvk::mesh
