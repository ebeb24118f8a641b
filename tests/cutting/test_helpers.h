// Meshes and blades for the cutting tests.
#pragma once

#include "blobvk/cutting/blade.h"
#include "blobvk/mesh/tetmesh.h"

#include <random>

namespace blobvk::cutting::test {

// n x n x n voxels of size h from the origin, 6 tets per voxel (thesis voxel split), positive.
mesh::TetMesh cubeMesh(int n, double h = 1.0);

// One tet with the given corners (reordered to positive orientation if needed).
mesh::TetMesh singleTet(mesh::Double3 a, mesh::Double3 b, mesh::Double3 c, mesh::Double3 d);

// A random well-shaped tet: a regular tet under a random rotation, anisotropic scale (<= 2x)
// and translation.
mesh::TetMesh randomTet(std::mt19937& rng);

// Blade keyframes whose swept quad is the planar square centred at `centre`, spanned by the
// orthonormal directions u, v (half-size `half`): the blade is the segment along v, moving along u.
BladePath squareSweep(mesh::Double3 centre, mesh::Double3 u, mesh::Double3 v, double half);

// Swept triangles of the square above (one step).
std::vector<Triangle> squareTriangles(mesh::Double3 centre, mesh::Double3 u, mesh::Double3 v, double half);

double relativeDifference(double a, double b);

}  // namespace blobvk::cutting::test
