// Tetrahedron quality metrics (thesis §6.8, with the inscribed radius corrected to 3V/sum(A)) and
// mesh statistics with a TetGen-style dihedral-angle histogram.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <cstddef>
#include <string>

namespace blobvk::cutting {

struct TetQuality {
  double volume = 0;           // signed
  double inradius = 0;         // 3V / sum of face areas
  double circumradius = 0;
  double radiusRatio = 0;      // 3 r / R: 1 for the regular tet, -> 0 when degenerate
  double aspectRatio = 0;      // R / (3 r) (thesis AR, corrected): 1 for the regular tet
  double minDihedralDeg = 0, maxDihedralDeg = 0;
  double minEdge = 0, maxEdge = 0;
  std::array<double, 6> dihedralDeg{};
};
TetQuality tetQuality(mesh::Double3 a, mesh::Double3 b, mesh::Double3 c, mesh::Double3 d);

// Dihedral histogram bin edges (degrees), as printed by `tetgen -V`.
inline constexpr std::array<double, 21> kDihedralBins = {0,  5,  10, 20,  30,  40,  50,  60,  70,  80, 90,
                                                         100, 110, 120, 130, 140, 150, 160, 170, 175, 180};

struct QualityStats {
  std::size_t tets = 0;
  double minVolume = 0, maxVolume = 0, volumeRatio = 0;  // max / min
  double minEdge = 0, maxEdge = 0, edgeRatio = 0;        // over all edges, max / min
  double minRadiusRatio = 0, radiusRatioP1 = 0;          // minimum and 1st percentile
  double maxAspectRatio = 0;
  double minDihedralDeg = 0, maxDihedralDeg = 0;
  double totalVolume = 0;
  std::array<std::size_t, 20> dihedralHistogram{};  // all 6 angles of every tet
  std::string summary() const;     // one line
  std::string histogram() const;   // one line per non-empty bin
};

// Statistics of the mesh at rest (useRest) or in its current positions.
QualityStats meshQuality(const mesh::TetMesh& mesh, bool useRest = true);

}  // namespace blobvk::cutting
