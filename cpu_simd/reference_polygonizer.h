// Reference polygonizer: marching cubes over the whole grid with the scalar evaluator, one
// thread. Slow and plain on purpose: the MPU/AVX polygonizer and the GPU are checked against it.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"

namespace blobvk::cpu {

struct ReferenceOptions {
  bool normals = true;   // -gradient of the field (analytic), normalised
  bool colours = true;
  int refineSteps = 0;   // extra bisection/secant steps on each crossing edge (0: linear interp.)
};

// Vertices lie on crossing grid edges, one per edge (welded), sorted by global edge key
// (GridSpec::edgeKey), which TriMesh::edgeKeys records. Triangles follow cell order (cell index
// = pointIndex of its lowest corner) and, inside a cell, the case table's order.
mesh::TriMesh polygonizeReference(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                  const ReferenceOptions& options = {});

}  // namespace blobvk::cpu
