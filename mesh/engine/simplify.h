// Mesh simplification with meshoptimizer's edge-collapse simplifier, guarded so that a closed
// mesh stays closed: back-to-back triangle pairs left by collapses are removed, a result that is
// still not watertight (or changed the Euler characteristic) is retried with gentler triangle
// targets above the count that opened it, within the same error bound (doublings, then a bisection
// of the first octave that closes it), and the input is kept when no gentler target closes it
// either. The report says which happened.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <cstddef>
#include <string>
#include <string_view>

namespace blobvk::mesh {

struct SimplifyTarget {
  enum class Kind { Ratio, Error } kind = Kind::Ratio;
  // Ratio: the fraction of triangles to keep, in (0, 1]. Error: the largest deviation allowed,
  // relative to the mesh's extent (meshoptimizer's measure; 0.01 = 1 %), in (0, 1].
  float value = 1.0f;
};

// "0.25" keeps a quarter of the triangles; "0.5%" allows an error of 0.5 % of the extent.
// Throws std::invalid_argument with one line naming the text and the problem.
SimplifyTarget parseSimplifyTarget(std::string_view text);

struct SimplifyReport {
  std::size_t trianglesBefore = 0, trianglesAfter = 0;
  float error = 0.0f;           // reached deviation, relative to the extent
  bool watertightBefore = false, watertightAfter = false;
  // What the requested target reached (an error target: the fewest triangles within the error).
  // When that opened the mesh, backedOff is set and the result has more triangles than asked for.
  std::size_t trianglesFirstTry = 0;
  bool backedOff = false;
  bool keptInput = false;       // every try opened the mesh: the input is returned unchanged
  int attempts = 0;             // simplifier runs (1 when the first target kept it closed)
  std::string summary() const;  // one clause for the CLI's check line
};

// The simplified mesh: a subset of the input's vertices (normals and colours follow them), packed
// in first-use order; edge keys are dropped (vertices no longer lie in grid-edge order). A mesh
// with a boundary keeps its border vertices where they are (meshopt_SimplifyLockBorder).
TriMesh simplifyMesh(const TriMesh& mesh, const SimplifyTarget& target, SimplifyReport* report = nullptr);

}  // namespace blobvk::mesh
