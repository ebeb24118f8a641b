// Mesh checks: topology (closed, edge-manifold, consistently oriented, Euler characteristic) and
// the enclosed volume. Used by tests, `blobvk info/compare` and the FEM input validation.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <cstddef>
#include <string>

namespace blobvk::mesh {

struct MeshReport {
  std::size_t vertices = 0, triangles = 0, edges = 0;
  std::size_t boundaryEdges = 0;      // used by one triangle
  std::size_t nonManifoldEdges = 0;   // used by three or more
  std::size_t misorientedEdges = 0;   // two triangles traverse it in the same direction
  std::size_t degenerateTriangles = 0;  // repeated vertex index
  std::size_t unreferencedVertices = 0;
  long long eulerCharacteristic = 0;  // V - E + F
  std::size_t components = 0;         // connected by shared edges
  double volume = 0.0;                // signed, from the divergence theorem; > 0 when outward
  double area = 0.0;

  bool closed() const { return boundaryEdges == 0; }
  bool manifold() const { return nonManifoldEdges == 0; }
  bool oriented() const { return misorientedEdges == 0; }
  bool watertight() const { return closed() && manifold() && oriented() && degenerateTriangles == 0; }
  std::string summary() const;  // one line for the CLI
};

MeshReport checkMesh(const TriMesh& mesh);

}  // namespace blobvk::mesh
