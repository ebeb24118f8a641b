// Symmetric Hausdorff distance between the vertex sets of two meshes (a spatial hash makes each
// nearest-vertex query O(1) on meshes whose vertices lie on the same grid's edges).
#pragma once

#include "blobvk/mesh/trimesh.h"

namespace blobvk::app {

double vertexHausdorff(const mesh::TriMesh& a, const mesh::TriMesh& b, float cellSize);

}  // namespace blobvk::app
