#include "blobvk/fem/tet_utils.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::fem {

double tetVolume(const std::vector<Double3>& p, const std::array<std::uint32_t, 4>& t) {
  const Double3 &a = p[t[0]], &b = p[t[1]], &c = p[t[2]], &d = p[t[3]];
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
  return (ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)) / 6.0;
}

double totalVolume(const TetMesh& mesh, bool rest) {
  const auto& p = rest ? mesh.restPositions : mesh.positions;
  double sum = 0;
  for (const auto& t : mesh.tets) sum += tetVolume(p, t);
  return sum;
}

void orientTets(TetMesh& mesh) {
  for (auto& t : mesh.tets)
    if (tetVolume(mesh.restPositions, t) < 0) std::swap(t[2], t[3]);
}

std::vector<std::array<std::uint32_t, 3>> findBoundaryFaces(const TetMesh& mesh) {
  // Faces opposite each node, oriented outward for a positively oriented tet.
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Entry {
    std::array<std::uint32_t, 3> key;     // sorted node ids
    std::array<std::uint32_t, 3> oriented;
  };
  std::vector<Entry> faces;
  faces.reserve(mesh.tets.size() * 4);
  for (const auto& t : mesh.tets)
    for (const auto& f : kFaces) {
      Entry e{{t[f[0]], t[f[1]], t[f[2]]}, {t[f[0]], t[f[1]], t[f[2]]}};
      std::sort(e.key.begin(), e.key.end());
      faces.push_back(e);
    }
  std::sort(faces.begin(), faces.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
  std::vector<std::array<std::uint32_t, 3>> boundary;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) boundary.push_back(faces[i].oriented);
    i = j;
  }
  return boundary;
}

void validateTetMesh(const TetMesh& mesh) {
  if (mesh.tets.empty()) throw std::invalid_argument("tet mesh has no tetrahedra");
  if (mesh.restPositions.size() != mesh.positions.size())
    throw std::invalid_argument("tet mesh: " + std::to_string(mesh.positions.size()) + " positions but " +
                                std::to_string(mesh.restPositions.size()) + " rest positions");
  if (!mesh.regions.empty() && mesh.regions.size() != mesh.tets.size())
    throw std::invalid_argument("tet mesh: regions must be empty or one per tet");
  const std::size_t n = mesh.positions.size();
  double meanAbs = 0;
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    const auto& t = mesh.tets[i];
    for (int a = 0; a < 4; ++a) {
      if (t[a] >= n)
        throw std::invalid_argument("tet " + std::to_string(i) + " references node " + std::to_string(t[a]) +
                                    " but the mesh has " + std::to_string(n) + " nodes");
      for (int b = 0; b < a; ++b)
        if (t[a] == t[b]) throw std::invalid_argument("tet " + std::to_string(i) + " repeats node " + std::to_string(t[a]));
    }
    meanAbs += std::abs(tetVolume(mesh.restPositions, t));
  }
  meanAbs /= double(mesh.tets.size());
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    const double v = tetVolume(mesh.restPositions, mesh.tets[i]);
    if (!(v > 1e-12 * meanAbs))
      throw std::invalid_argument("tet " + std::to_string(i) + " is degenerate or inverted at rest (volume " +
                                  std::to_string(v) + ", mean " + std::to_string(meanAbs) + ")");
  }
}

void assignRegions(TetMesh& mesh, const RegionSelector& selector) {
  mesh.regions.resize(mesh.tets.size());
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    Double3 c;
    for (auto n : mesh.tets[i]) {
      c.x += mesh.restPositions[n].x / 4;
      c.y += mesh.restPositions[n].y / 4;
      c.z += mesh.restPositions[n].z / 4;
    }
    mesh.regions[i] = selector(c);
  }
}

}  // namespace blobvk::fem
