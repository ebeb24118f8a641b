#include "blobvk/mesh/unreferenced.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::mesh {
namespace {

// Moves the entries of `values` that `newIndex` keeps to their new places, in order.
template <class T>
void keepReferenced(MeshArray<T>& values, const std::vector<std::uint32_t>& newIndex, std::size_t kept) {
  if (values.size() != newIndex.size()) return;  // an empty (or foreign-sized) attribute stays as is
  for (std::size_t v = 0; v < newIndex.size(); ++v)
    if (newIndex[v] != UINT32_MAX) values[newIndex[v]] = values[v];  // newIndex[v] <= v
  values.resize(kept);
}

}  // namespace

std::size_t dropUnreferencedVertices(TriMesh& mesh) {
  const std::size_t n = mesh.positions.size();
  std::vector<std::uint32_t> newIndex(n, UINT32_MAX);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) {
      if (v >= n)
        throw std::out_of_range("dropUnreferencedVertices: triangle index " + std::to_string(v) + " past the last of " +
                                std::to_string(n) + " vertices");
      newIndex[v] = 0;
    }
  std::uint32_t kept = 0;
  for (std::uint32_t& i : newIndex)
    if (i == 0) i = kept++;
  if (kept == n) return 0;
  for (auto& t : mesh.triangles)
    for (std::uint32_t& v : t) v = newIndex[v];
  keepReferenced(mesh.positions, newIndex, kept);
  keepReferenced(mesh.normals, newIndex, kept);
  keepReferenced(mesh.colours, newIndex, kept);
  keepReferenced(mesh.edgeKeys, newIndex, kept);
  return n - kept;
}

}  // namespace blobvk::mesh
