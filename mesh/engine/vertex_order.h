// Vertex-cache and vertex-fetch ordering (meshoptimizer): triangles reordered for the GPU's
// post-transform cache (Forsyth-style, meshopt_optimizeVertexCache), then vertices renumbered in
// first-use order (meshopt_optimizeVertexFetchRemap) with every attribute following. The surface
// is unchanged: the same triangles with the same winding, so closedness and volume are kept.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <string>

namespace blobvk::mesh {

struct VertexOrderReport {
  // Average cache misses per triangle for a 16-entry FIFO cache, before and after (1/2 ideal, 3 worst).
  float acmrBefore = 0.0f, acmrAfter = 0.0f;
  // Bytes fetched over bytes stored for a 64-byte-line cache, before and after (1 is ideal).
  float overfetchBefore = 0.0f, overfetchAfter = 0.0f;
  std::string summary() const;  // one clause for the CLI's check line
};

// Reorders `mesh` in place; edge keys are dropped (the order is no longer the grid-edge order).
VertexOrderReport optimizeVertexOrder(TriMesh& mesh);

}  // namespace blobvk::mesh
