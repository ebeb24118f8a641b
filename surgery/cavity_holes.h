// Hole points for TetGen from the model's field: TetGen fills every region a
// surface encloses, so a hollow body (eggshell_sim's shell, the gap between the
// craniotomy's skull and brain) would come out solid without one point inside
// each cavity.
#pragma once

#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <functional>
#include <vector>

namespace blobvk::surgery {

// The field of the model at a point (inside where >= iso).
using FieldAt = std::function<double(const mesh::Double3 &)>;

// One point inside each cavity of a closed, outward-oriented surface: a
// connected component with negative signed volume bounds a cavity (its normals
// point into the hollow). The point is stepped `step` along the normal of one
// of the component's larger triangles and kept only where the field says it is
// outside the material (< iso); a component with no such triangle gives no
// point. Deterministic: components in order of their first vertex.
std::vector<mesh::Double3> cavityHolePoints(const mesh::TriMesh &surface,
                                            const FieldAt &field, double iso,
                                            double step);

} // namespace blobvk::surgery
