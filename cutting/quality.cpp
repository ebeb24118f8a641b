#include "blobvk/cutting/quality.h"

#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

namespace blobvk::cutting {

TetQuality tetQuality(Double3 a, Double3 b, Double3 c, Double3 d) {
  TetQuality q;
  const std::array<Double3, 4> p{a, b, c, d};
  q.volume = tetVolume(a, b, c, d);
  const double v = std::fabs(q.volume);
  // Outward face normals (magnitude = 2 * area) of the faces opposite each node.
  std::array<Double3, 4> normal;
  double areaSum = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Double3 x = p[(i + 1) % 4], y = p[(i + 2) % 4], z = p[(i + 3) % 4];
    Double3 n = cross(y - x, z - x);
    if (dot(n, p[i] - x) > 0) n = n * -1.0;
    normal[i] = n;
    areaSum += 0.5 * length(n);
  }
  q.inradius = areaSum > 0 ? 3.0 * v / areaSum : 0.0;
  const Double3 u = b - a, w = c - a, s = d - a;
  const Double3 num = cross(w, s) * dot(u, u) + cross(s, u) * dot(w, w) + cross(u, w) * dot(s, s);
  q.circumradius = v > 0 ? length(num) / (12.0 * v) : INFINITY;
  q.radiusRatio = v > 0 ? 3.0 * q.inradius / q.circumradius : 0.0;
  q.aspectRatio = q.radiusRatio > 0 ? 1.0 / q.radiusRatio : INFINITY;
  q.minEdge = INFINITY;
  q.maxEdge = 0;
  q.minDihedralDeg = 180;
  q.maxDihedralDeg = 0;
  int k = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double len = length(p[i] - p[j]);
      q.minEdge = std::min(q.minEdge, len);
      q.maxEdge = std::max(q.maxEdge, len);
      // The edge (i, j) is shared by the faces opposite the two other nodes k0, k1; the interior
      // dihedral angle is pi minus the angle between their outward normals.
      int others[2], m = 0;
      for (int o = 0; o < 4; ++o)
        if (o != i && o != j) others[m++] = o;
      const Double3 n0 = normal[others[0]], n1 = normal[others[1]];
      const double denom = length(n0) * length(n1);
      const double cosine = denom > 0 ? std::clamp(dot(n0, n1) / denom, -1.0, 1.0) : 1.0;
      const double angle = 180.0 - std::acos(cosine) * 180.0 / std::numbers::pi;
      q.dihedralDeg[k++] = angle;
      q.minDihedralDeg = std::min(q.minDihedralDeg, angle);
      q.maxDihedralDeg = std::max(q.maxDihedralDeg, angle);
    }
  return q;
}

QualityStats meshQuality(const mesh::TetMesh& mesh, bool useRest) {
  QualityStats s;
  const auto& p = useRest ? mesh.restPositions : mesh.positions;
  s.tets = mesh.tets.size();
  if (s.tets == 0) return s;
  std::vector<double> ratios;
  ratios.reserve(s.tets);
  s.minVolume = s.minEdge = s.minRadiusRatio = INFINITY;
  s.minDihedralDeg = 180;
  for (const auto& t : mesh.tets) {
    const TetQuality q = tetQuality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
    s.totalVolume += q.volume;
    s.minVolume = std::min(s.minVolume, q.volume);
    s.maxVolume = std::max(s.maxVolume, q.volume);
    s.minEdge = std::min(s.minEdge, q.minEdge);
    s.maxEdge = std::max(s.maxEdge, q.maxEdge);
    s.minRadiusRatio = std::min(s.minRadiusRatio, q.radiusRatio);
    s.maxAspectRatio = std::max(s.maxAspectRatio, q.aspectRatio);
    s.minDihedralDeg = std::min(s.minDihedralDeg, q.minDihedralDeg);
    s.maxDihedralDeg = std::max(s.maxDihedralDeg, q.maxDihedralDeg);
    ratios.push_back(q.radiusRatio);
    for (double angle : q.dihedralDeg) {
      std::size_t bin = std::size_t(std::upper_bound(kDihedralBins.begin(), kDihedralBins.end(), angle) -
                                    kDihedralBins.begin());
      bin = std::clamp<std::size_t>(bin, 1, s.dihedralHistogram.size()) - 1;
      ++s.dihedralHistogram[bin];
    }
  }
  s.volumeRatio = s.minVolume > 0 ? s.maxVolume / s.minVolume : INFINITY;
  s.edgeRatio = s.minEdge > 0 ? s.maxEdge / s.minEdge : INFINITY;
  const std::size_t p1 = ratios.size() / 100;
  std::nth_element(ratios.begin(), ratios.begin() + p1, ratios.end());
  s.radiusRatioP1 = ratios[p1];
  return s;
}

std::string QualityStats::summary() const {
  std::ostringstream o;
  o << tets << " tets, volume " << totalVolume << " [" << minVolume << ", " << maxVolume << "] ratio " << volumeRatio
    << ", edge [" << minEdge << ", " << maxEdge << "] ratio " << edgeRatio << ", radius ratio min " << minRadiusRatio
    << " p1 " << radiusRatioP1 << ", max aspect " << maxAspectRatio << ", dihedral [" << minDihedralDeg << ", "
    << maxDihedralDeg << "] deg";
  return o.str();
}

std::string QualityStats::histogram() const {
  std::ostringstream o;
  for (std::size_t i = 0; i < dihedralHistogram.size(); ++i)
    if (dihedralHistogram[i])
      o << kDihedralBins[i] << "-" << kDihedralBins[i + 1] << " deg: " << dihedralHistogram[i] << "\n";
  return o.str();
}

}  // namespace blobvk::cutting
