// The render surface follows the body: each surface vertex is a fixed affine combination of up to
// 4 tet nodes (barycentric coordinates in its rest tet, or one node with weight 1).
#pragma once

#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::fem {

struct SurfaceEmbedding {
  std::vector<std::array<std::uint32_t, 4>> nodes;
  std::vector<std::array<double, 4>> weights;  // sum to 1
  std::size_t size() const { return nodes.size(); }
};

// Vertex i = node i (TetGen output: input surface points are the first nodes).
SurfaceEmbedding identityEmbedding(std::size_t vertexCount);
// Barycentric coordinates of each point in the rest tet that contains it; a point outside every
// tet uses the nearest tet (by centroid, among tets in nearby cells) with extrapolated weights,
// which is still exact for affine motions.
SurfaceEmbedding embedPoints(const mesh::TetMesh& mesh, std::span<const mesh::Float3> points);

// Writes the embedded vertex positions of `surface` from node positions and recomputes normals.
void applyEmbedding(const SurfaceEmbedding& embedding, const std::vector<mesh::Double3>& nodePositions,
                    mesh::TriMesh& surface);
// Area-weighted vertex normals.
void computeNormals(mesh::TriMesh& surface);
// The tet boundary as a TriMesh over all nodes (unused nodes are kept so indices match).
mesh::TriMesh boundarySurface(const mesh::TetMesh& mesh);

}  // namespace blobvk::fem
