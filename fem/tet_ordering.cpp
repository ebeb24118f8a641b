#include "blobvk/fem/tet_ordering.h"

#include "blobvk/fem/tet_utils.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <vector>

namespace blobvk::fem {
namespace {

std::array<double, 3> coords(const Double3& p) { return {p.x, p.y, p.z}; }

// Position on a Z-order curve of 2^10 cells per axis over the points' bounding box.
struct ZOrder {
  std::array<double, 3> lo{}, scale{};

  explicit ZOrder(const std::vector<Double3>& points) {
    std::array<double, 3> hi = points.empty() ? lo : coords(points[0]);
    lo = hi;
    for (const Double3& p : points)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], coords(p)[a]), hi[a] = std::max(hi[a], coords(p)[a]);
    for (int a = 0; a < 3; ++a) scale[a] = hi[a] > lo[a] ? 1023.999 / (hi[a] - lo[a]) : 0.0;
  }

  static std::uint32_t spread(std::uint32_t v) {  // bit i -> bit 3i
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    return (v | (v << 2)) & 0x09249249u;
  }

  std::uint32_t code(const Double3& p) const {
    const std::array<double, 3> q = coords(p);
    std::uint32_t c = 0;
    for (int a = 0; a < 3; ++a) {
      const double cell = std::clamp((q[a] - lo[a]) * scale[a], 0.0, 1023.0);
      c |= spread(std::uint32_t(cell)) << a;
    }
    return c;
  }
};

// Indices [0, codes.size()) sorted by code, ties in index order.
std::vector<std::uint32_t> sortedByCode(const std::vector<std::uint32_t>& codes) {
  std::vector<std::uint32_t> order(codes.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return codes[a] < codes[b]; });
  return order;
}

}  // namespace

void orderForLocality(mesh::TetMesh& mesh, std::size_t keepNodes) {
  const std::size_t nodes = mesh.nodeCount();
  if (keepNodes > nodes) throw std::invalid_argument("orderForLocality: more nodes to keep than the mesh has");
  const ZOrder curve(mesh.restPositions);

  // Nodes: those from keepNodes on in Z-order; newIndex[old] = new.
  std::vector<std::uint32_t> codes(nodes - keepNodes);
  for (std::size_t i = keepNodes; i < nodes; ++i) codes[i - keepNodes] = curve.code(mesh.restPositions[i]);
  const std::vector<std::uint32_t> nodeOrder = sortedByCode(codes);
  std::vector<std::uint32_t> newIndex(nodes);
  std::iota(newIndex.begin(), newIndex.begin() + std::ptrdiff_t(keepNodes), 0u);
  std::vector<Double3> positions(mesh.positions.begin(), mesh.positions.begin() + std::ptrdiff_t(keepNodes));
  std::vector<Double3> rest(mesh.restPositions.begin(), mesh.restPositions.begin() + std::ptrdiff_t(keepNodes));
  positions.reserve(nodes), rest.reserve(nodes);
  for (std::uint32_t k : nodeOrder) {
    const std::size_t old = keepNodes + k;
    newIndex[old] = std::uint32_t(positions.size());
    positions.push_back(mesh.positions[old]);
    rest.push_back(mesh.restPositions[old]);
  }

  // Tets in Z-order of their centroids, their nodes renumbered.
  codes.resize(mesh.tetCount());
  for (std::size_t t = 0; t < mesh.tetCount(); ++t) {
    Double3 c{};
    for (std::uint32_t n : mesh.tets[t]) {
      const Double3& p = mesh.restPositions[n];
      c = {c.x + 0.25 * p.x, c.y + 0.25 * p.y, c.z + 0.25 * p.z};
    }
    codes[t] = curve.code(c);
  }
  const std::vector<std::uint32_t> tetOrder = sortedByCode(codes);
  std::vector<std::array<std::uint32_t, 4>> tets(mesh.tetCount());
  std::vector<std::uint32_t> regions(mesh.regions.empty() ? 0 : mesh.tetCount());
  for (std::size_t t = 0; t < tetOrder.size(); ++t) {
    for (int k = 0; k < 4; ++k) tets[t][k] = newIndex[mesh.tets[tetOrder[t]][k]];
    if (!regions.empty()) regions[t] = mesh.regions[tetOrder[t]];
  }
  mesh.positions = std::move(positions);
  mesh.restPositions = std::move(rest);
  mesh.tets = std::move(tets);
  mesh.regions = std::move(regions);
  mesh.boundaryFaces = findBoundaryFaces(mesh);
}

}  // namespace blobvk::fem
