// meshoptimizer's vertex-cache and vertex-fetch ordering over a TriMesh (see vertex_order.h).
#include "blobvk/mesh/engine/vertex_order.h"

#include <meshoptimizer.h>

#include <cstdio>
#include <vector>

namespace blobvk::mesh {

namespace {

constexpr unsigned kCacheSize = 16;  // a common post-transform cache size for the ACMR figure

void measure(const TriMesh& mesh, const std::vector<unsigned>& indices, float& acmr, float& overfetch) {
  if (indices.empty()) return;
  acmr = meshopt_analyzeVertexCache(indices.data(), indices.size(), mesh.positions.size(), kCacheSize, 0, 0).acmr;
  // Stored vertex size: what a glTF export writes per vertex.
  const std::size_t vertexBytes = sizeof(Float3) * (1 + (mesh.normals.empty() ? 0 : 1) + (mesh.colours.empty() ? 0 : 1));
  overfetch = meshopt_analyzeVertexFetch(indices.data(), indices.size(), mesh.positions.size(), vertexBytes).overfetch;
}

template <class T, class A>
void permute(std::vector<T, A>& values, const std::vector<unsigned>& remap, std::size_t count) {
  if (values.empty()) return;
  std::vector<T, A> out(count, T{});
  for (std::size_t v = 0; v < values.size(); ++v)
    if (remap[v] != ~0u) out[remap[v]] = values[v];
  values = std::move(out);
}

}  // namespace

VertexOrderReport optimizeVertexOrder(TriMesh& mesh) {
  VertexOrderReport r;
  std::vector<unsigned> indices(mesh.triangles.size() * 3);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) indices[3 * t + std::size_t(k)] = mesh.triangles[t][std::size_t(k)];
  measure(mesh, indices, r.acmrBefore, r.overfetchBefore);

  meshopt_optimizeVertexCache(indices.data(), indices.data(), indices.size(), mesh.positions.size());
  std::vector<unsigned> remap(mesh.positions.size());
  const std::size_t n = meshopt_optimizeVertexFetchRemap(remap.data(), indices.data(), indices.size(), mesh.positions.size());
  permute(mesh.positions, remap, n);
  permute(mesh.normals, remap, n);
  permute(mesh.colours, remap, n);
  mesh.edgeKeys.clear();
  meshopt_remapIndexBuffer(indices.data(), indices.data(), indices.size(), remap.data());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    mesh.triangles[t] = {indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]};
  measure(mesh, indices, r.acmrAfter, r.overfetchAfter);
  return r;
}

std::string VertexOrderReport::summary() const {
  char line[160];
  std::snprintf(line, sizeof line, "vertex order: ACMR %.3f -> %.3f, overfetch %.3f -> %.3f", double(acmrBefore),
                double(acmrAfter), double(overfetchBefore), double(overfetchAfter));
  return line;
}

}  // namespace blobvk::mesh
