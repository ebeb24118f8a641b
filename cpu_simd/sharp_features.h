// Sharp features (`blobvk mesh --features`): extended marching cubes' feature vertices as a pass
// over a polygonizer's mesh. Marching cubes puts vertices only on grid edges, so a crease or a
// corner of a CSG model (a difference, an intersection) comes out chamfered and stair-stepped at
// any resolution. Where the analytic normals of a cell's vertices disagree by more than an angle,
// the cell's patch is replaced by a fan around one new vertex at the point that best fits all the
// tangent planes (a quadric error function solved with a truncated pseudo-inverse), and the
// edges between two such fans are flipped so that neighbouring feature vertices are joined
// along the crease.
//
// The pass needs what every polygonizer here gives: vertices on grid edges with their global
// edge keys, analytic normals, triangles in cell order. It keeps the mesh closed, manifold and
// oriented (a fan has the boundary of the patch it replaces; a cell whose fit lands outside it
// or whose fan would fold keeps its marching-cubes patch), is deterministic (cells in order,
// one thread), and gives the same mesh after either backend where they give the same input.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/mesh/trimesh.h"

#include <cstddef>

namespace blobvk::cpu {

struct FeatureOptions {
  float creaseDegrees = 30.0f;  // normals of one cell further apart than this mark a feature
  // Directions of the fit whose singular value is below this fraction of the largest are left
  // at the vertices' mean (along a crease the fit is free in one direction, on a face in two).
  float singularRatio = 0.1f;
  bool flipEdges = true;        // join neighbouring feature vertices along the crease
};

struct FeatureReport {
  std::size_t featureCells = 0;     // cells whose normals disagree
  std::size_t featureVertices = 0;  // of those, replaced by a fan
  std::size_t rejected = 0;         // kept as they were: notADisc + folds
  std::size_t notADisc = 0;         // the cell's patch is several pieces (an ambiguous cube) or not a disc
  std::size_t folds = 0;            // a fan triangle would face against its vertices' normals
  std::size_t flips = 0;
};

// Feature vertices are appended after the mesh's vertices, in cell order, with the edge key
// 3 * grid.pointCount() + cell index (past every grid edge's key), the mean colour of their
// cell's vertices and the mean of their normals. Throws std::invalid_argument when the mesh has
// no edge keys or no normals.
void placeSharpFeatures(mesh::TriMesh& mesh, const blobtree::GridSpec& grid, const FeatureOptions& options = {},
                        FeatureReport* report = nullptr);

}  // namespace blobvk::cpu
