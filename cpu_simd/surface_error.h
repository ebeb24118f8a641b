// How far a mesh lies from a surface given as a much finer mesh of it: point-to-triangle
// distances both ways (the mesh's vertices and triangle centroids to the reference's triangles,
// the reference's vertices to the mesh's triangles). Measures a polygonizer's geometric error
// (sharp features against plain marching cubes); not used while meshing.
#pragma once

#include "blobvk/mesh/trimesh.h"

namespace blobvk::cpu {

struct SurfaceError {
  double toReference = 0.0;    // largest distance from the mesh to the reference
  double fromReference = 0.0;  // largest distance from the reference to the mesh
  double meanToReference = 0.0;
  mesh::Float3 worstTo, worstFrom;  // where the two largest distances were found
  double hausdorff() const { return toReference > fromReference ? toReference : fromReference; }
};

// `bucket` is the spatial hash's cell size (about the coarser mesh's edge length).
SurfaceError surfaceError(const mesh::TriMesh& mesh, const mesh::TriMesh& reference, double bucket);

}  // namespace blobvk::cpu
