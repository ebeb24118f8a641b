// Isotropic remeshing of a closed triangle surface, to give TetGen well-shaped input. Marching
// cubes leaves triangles with angles below 1 degree; TetGen must keep input facets, so its
// tetrahedra inherit those angles (minimum dihedral ~0.1 degree) and it over-refines around them.
// The passes (Botsch & Kobbelt 2004): split edges longer than 4/3 L, collapse edges shorter than
// 4/5 L (link condition, no normal flips, no new long edges), flip edges where that raises the
// smaller angle of the two triangles (a guard on the normals keeps the shape), then move each
// vertex tangentially towards the centroid of its neighbours and project it back onto the
// surface. Topology (Euler characteristic, components) is kept; the result is closed and
// 2-manifold. Single-threaded and deterministic.
#pragma once

#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <cstddef>
#include <functional>
#include <vector>

namespace blobvk::mesh {

// Moves a point near the surface onto it (e.g. Newton steps on an implicit field).
using SurfaceProjection = std::function<Double3(const Double3&)>;
// The same for many points at once, in place: lets the caller evaluate its field in SIMD
// batches (the remesher projects every vertex of a relaxation round in one call).
using SurfaceProjectionBatch = std::function<void(std::vector<Double3>& points)>;
// values[i] = field(points[i]) for every point (values is resized by the callee).
using FieldBatch = std::function<void(const std::vector<Double3>& points, std::vector<double>& values)>;

struct SurfaceRemeshOptions {
  double targetEdgeLength = 0;  // L, > 0; e.g. the polygonizer's cell size
  int iterations = 5;           // split / collapse / flip / relax rounds
  // Where vertices go after each move. Empty: they stay on the tangent plane of the current
  // surface (no projection), which shrinks curved regions slightly (O(L^2) per round).
  SurfaceProjection project;
  // Used instead of `project` when set (same contract, many points per call).
  SurfaceProjectionBatch projectBatch;
  // Flips and collapses are refused where a triangle normal would turn by more than this.
  double maxNormalTurnDegrees = 30;
  // Refuse (or undo) every edit that would make a triangle cross another one: keeps a shell
  // thinner than the target edge length from folding into itself. Costs ~10-20 % of the time.
  bool preventSelfIntersections = true;
};

struct SurfaceRemeshStats {
  std::size_t splits = 0, collapses = 0, flips = 0;
  std::size_t undoneMoves = 0;  // projections / relaxation moves put back because a face would cross another
  double minAngleBeforeDegrees = 0, minAngleAfterDegrees = 0;
};

// The remeshed surface (positions and triangles only: normals, colours and edge keys are
// dropped, they no longer match). Throws std::invalid_argument for a surface that is not closed,
// manifold and oriented, or a non-positive target length.
TriMesh remeshSurface(const TriMesh& surface, const SurfaceRemeshOptions& options, SurfaceRemeshStats* stats = nullptr);

// Smallest interior angle over all triangles, in degrees (0 for a degenerate one).
double minTriangleAngleDegrees(const TriMesh& mesh);

// A projection onto the level set field = iso by Newton steps along a central-difference
// gradient (step h): for implicit models whose field and surface are known only as a function.
SurfaceProjection isoSurfaceProjection(std::function<double(const Double3&)> field, double iso, double h, int steps = 2);
// The batch form: each Newton step evaluates the field once for all 7 x n points (each point and
// its 6 central-difference neighbours). Gives the same points as the scalar form for the same field.
SurfaceProjectionBatch isoSurfaceProjectionBatch(FieldBatch field, double iso, double h, int steps = 2);

}  // namespace blobvk::mesh
