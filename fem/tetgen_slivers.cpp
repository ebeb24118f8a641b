#include "blobvk/fem/tetgen_slivers.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>

namespace blobvk::fem {
namespace {

using mesh::Double3;
using Tet = std::array<std::uint32_t, 4>;

Double3 operator+(const Double3& a, const Double3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Double3 operator-(const Double3& a, const Double3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Double3 operator*(const Double3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(const Double3& a, const Double3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Double3 cross(const Double3& a, const Double3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Double3 normalized(const Double3& a) {
  const double l = std::sqrt(dot(a, a));
  return l > 0 ? a * (1.0 / l) : Double3{};
}

constexpr double kDegrees = 180.0 / std::numbers::pi;

// Outward unit normal of the face opposite corner k of tet t with corner positions p.
Double3 outwardNormal(const std::array<Double3, 4>& p, int k) {
  const Double3& a = p[std::size_t((k + 1) % 4)];
  const Double3& b = p[std::size_t((k + 2) % 4)];
  const Double3& c = p[std::size_t((k + 3) % 4)];
  Double3 n = normalized(cross(b - a, c - a));
  return dot(n, p[std::size_t(k)] - a) > 0 ? n * -1.0 : n;
}

double signedVolume(const std::array<Double3, 4>& p) { return dot(p[1] - p[0], cross(p[2] - p[0], p[3] - p[0])) / 6.0; }

// The dihedral angle at the edge shared by the faces opposite k and l is pi minus the angle
// between their outward normals: the smallest dihedral has the largest -dot(n_k, n_l).
double minDihedral(const std::array<Double3, 4>& p) {
  std::array<Double3, 4> n;
  for (int k = 0; k < 4; ++k) n[std::size_t(k)] = outwardNormal(p, k);
  double worst = -1;
  for (int k = 0; k < 4; ++k)
    for (int l = k + 1; l < 4; ++l) worst = std::max(worst, -dot(n[std::size_t(k)], n[std::size_t(l)]));
  return std::acos(std::clamp(worst, -1.0, 1.0)) * kDegrees;
}

class SliverSmoother {
 public:
  SliverSmoother(mesh::TetMesh& mesh, std::size_t fixedNodes) : mesh_(mesh), points_(mesh.restPositions) {
    const std::size_t n = points_.size();
    std::vector<std::uint32_t> count(n + 1, 0);
    for (const Tet& t : mesh_.tets)
      for (std::uint32_t v : t) ++count[v + 1];
    for (std::size_t v = 0; v < n; ++v) count[v + 1] += count[v];
    starStart_ = count;
    starTets_.resize(count[n]);
    for (std::uint32_t t = 0; t < mesh_.tets.size(); ++t)
      for (std::uint32_t v : mesh_.tets[t]) starTets_[count[v]++] = t;
    classifyNodes(fixedNodes);
  }

  double tetQuality(std::uint32_t t) const { return minDihedral(corners(t, kNoNode, {})); }

  // Improves the star of v; returns whether v moved.
  bool improve(std::uint32_t v) {
    if (kind_[v] == Kind::Fixed) return false;
    double current = starQuality(v, points_[v]);
    bool moved = false;
    for (int iteration = 0; iteration < 12; ++iteration) {
      Double3 best = points_[v];
      double bestQuality = current;
      const double scale = meanEdge(v);
      for (const Double3& direction : directions(v)) {
        for (double step : {0.4, 0.2, 0.1, 0.05, 0.02}) {
          const Double3 candidate = points_[v] + direction * (step * scale);
          const double q = starQuality(v, candidate);
          if (q > bestQuality + 1e-9) {
            bestQuality = q;
            best = candidate;
          }
        }
      }
      if (!(bestQuality > current)) break;
      points_[v] = best;
      current = bestQuality;
      moved = true;
    }
    return moved;
  }

  std::span<const std::uint32_t> star(std::uint32_t v) const {
    return {starTets_.data() + starStart_[v], starStart_[v + 1] - starStart_[v]};
  }
  void store() {
    mesh_.restPositions = points_;
    mesh_.positions = points_;
  }

 private:
  enum class Kind : std::uint8_t { Free, Planar, Fixed };
  static constexpr std::uint32_t kNoNode = 0xffffffffu;

  // Fixed: input vertices, and boundary nodes whose boundary faces are not coplanar (on an
  // input edge or corner: moving them would change the surface).
  void classifyNodes(std::size_t fixedNodes) {
    const std::size_t n = points_.size();
    kind_.assign(n, Kind::Free);
    planeNormal_.assign(n, Double3{});
    boundaryStart_.assign(n + 1, 0);
    for (const auto& f : mesh_.boundaryFaces)
      for (std::uint32_t v : f) ++boundaryStart_[v + 1];
    for (std::size_t v = 0; v < n; ++v) boundaryStart_[v + 1] += boundaryStart_[v];
    std::vector<std::uint32_t> fill(boundaryStart_.begin(), boundaryStart_.end() - 1);
    boundaryFaces_.resize(boundaryStart_[n]);
    for (std::uint32_t f = 0; f < mesh_.boundaryFaces.size(); ++f)
      for (std::uint32_t v : mesh_.boundaryFaces[f]) boundaryFaces_[fill[v]++] = f;
    for (std::uint32_t v = 0; v < n; ++v) {
      if (v < fixedNodes) {
        kind_[v] = Kind::Fixed;
        continue;
      }
      if (boundaryStart_[v] == boundaryStart_[v + 1]) continue;
      kind_[v] = Kind::Planar;
      planeNormal_[v] = faceNormal(boundaryFaces_[boundaryStart_[v]], kNoNode, {});
      for (std::uint32_t i = boundaryStart_[v]; i < boundaryStart_[v + 1]; ++i)
        if (dot(faceNormal(boundaryFaces_[i], kNoNode, {}), planeNormal_[v]) < 1 - 1e-9) kind_[v] = Kind::Fixed;
    }
  }

  // Unit normal of boundary face f, with node `moved` at `at`.
  Double3 faceNormal(std::uint32_t f, std::uint32_t moved, const Double3& at) const {
    const auto& face = mesh_.boundaryFaces[f];
    std::array<Double3, 3> p;
    for (int k = 0; k < 3; ++k) p[std::size_t(k)] = face[std::size_t(k)] == moved ? at : points_[face[std::size_t(k)]];
    return normalized(cross(p[1] - p[0], p[2] - p[0]));
  }

  std::array<Double3, 4> corners(std::uint32_t t, std::uint32_t moved, const Double3& at) const {
    std::array<Double3, 4> p;
    for (int k = 0; k < 4; ++k) {
      const std::uint32_t v = mesh_.tets[t][std::size_t(k)];
      p[std::size_t(k)] = v == moved ? at : points_[v];
    }
    return p;
  }

  // Smallest dihedral angle over the star of v with v at p; -1 where a tet would invert or a
  // boundary face would flip (the move is then refused).
  double starQuality(std::uint32_t v, const Double3& p) const {
    double worst = 180;
    for (std::uint32_t i = starStart_[v]; i < starStart_[v + 1]; ++i) {
      const auto c = corners(starTets_[i], v, p);
      if (!(signedVolume(c) > 0)) return -1;
      worst = std::min(worst, minDihedral(c));
    }
    for (std::uint32_t i = boundaryStart_[v]; i < boundaryStart_[v + 1]; ++i)
      if (dot(faceNormal(boundaryFaces_[i], v, p), planeNormal_[v]) < 1 - 1e-9) return -1;
    return worst;
  }

  double meanEdge(std::uint32_t v) const {
    double sum = 0;
    int count = 0;
    for (std::uint32_t i = starStart_[v]; i < starStart_[v + 1]; ++i)
      for (std::uint32_t w : mesh_.tets[starTets_[i]])
        if (w != v) {
          sum += std::sqrt(dot(points_[w] - points_[v], points_[w] - points_[v]));
          ++count;
        }
    return count ? sum / count : 0;
  }

  // Search directions: away from the opposite face of the star's worst tet (a sliver's node
  // is too close to it), and towards the centroid of the star; both kept in the facet plane for
  // a boundary node.
  std::vector<Double3> directions(std::uint32_t v) const {
    std::uint32_t worstTet = starTets_[starStart_[v]];
    double worst = 181;
    Double3 centroid;
    int count = 0;
    for (std::uint32_t i = starStart_[v]; i < starStart_[v + 1]; ++i) {
      const std::uint32_t t = starTets_[i];
      const double q = tetQuality(t);
      if (q < worst) {
        worst = q;
        worstTet = t;
      }
      for (std::uint32_t w : mesh_.tets[t])
        if (w != v) {
          centroid = centroid + points_[w];
          ++count;
        }
    }
    const auto c = corners(worstTet, kNoNode, {});
    int k = 0;
    while (mesh_.tets[worstTet][std::size_t(k)] != v) ++k;
    // The outward normal of the face opposite v points away from v: its negation moves v away
    // from that face.
    std::vector<Double3> out = {outwardNormal(c, k) * -1.0, normalized(centroid * (1.0 / count) - points_[v])};
    if (kind_[v] == Kind::Planar) {
      for (Double3& d : out) d = normalized(d - planeNormal_[v] * dot(d, planeNormal_[v]));
    }
    return out;
  }

  mesh::TetMesh& mesh_;
  std::vector<Double3> points_;
  std::vector<std::uint32_t> starStart_, starTets_, boundaryStart_, boundaryFaces_;
  std::vector<Kind> kind_;
  std::vector<Double3> planeNormal_;
};

}  // namespace

double minDihedralDegrees(const std::vector<Double3>& points, const Tet& tet) {
  return minDihedral({points[tet[0]], points[tet[1]], points[tet[2]], points[tet[3]]});
}

SliverStats smoothSlivers(mesh::TetMesh& mesh, double boundDegrees, std::size_t fixedNodes) {
  SliverStats stats;
  std::vector<std::uint32_t> bad;
  for (std::uint32_t t = 0; t < mesh.tets.size(); ++t) {
    const double q = minDihedralDegrees(mesh.restPositions, mesh.tets[t]);
    stats.minDihedralBeforeDegrees = std::min(stats.minDihedralBeforeDegrees, q);
    if (q < boundDegrees) bad.push_back(t);
  }
  stats.tetsBelowBefore = bad.size();
  stats.minDihedralAfterDegrees = stats.minDihedralBeforeDegrees;
  if (bad.empty()) return stats;

  SliverSmoother smoother(mesh, fixedNodes);
  std::vector<std::uint32_t> moved;
  for (int round = 0; round < 6 && !bad.empty(); ++round) {
    const std::size_t movedBefore = moved.size();
    for (std::uint32_t t : bad)
      for (std::uint32_t v : mesh.tets[t])
        if (smoother.tetQuality(t) < boundDegrees && smoother.improve(v)) moved.push_back(v);
    if (moved.size() == movedBefore) break;
    // A move raises the worst tet of a star but may take another one of it below the bound.
    for (std::size_t i = movedBefore; i < moved.size(); ++i)
      for (std::uint32_t t : smoother.star(moved[i])) bad.push_back(t);
    std::sort(bad.begin(), bad.end());
    bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
    std::erase_if(bad, [&](std::uint32_t t) { return smoother.tetQuality(t) >= boundDegrees; });
  }
  smoother.store();
  std::sort(moved.begin(), moved.end());
  stats.nodesMoved = std::size_t(std::unique(moved.begin(), moved.end()) - moved.begin());
  stats.tetsBelowAfter = 0;
  stats.minDihedralAfterDegrees = 180;
  for (const Tet& t : mesh.tets) {
    const double q = minDihedralDegrees(mesh.restPositions, t);
    stats.minDihedralAfterDegrees = std::min(stats.minDihedralAfterDegrees, q);
    stats.tetsBelowAfter += q < boundDegrees ? 1 : 0;
  }
  return stats;
}

}  // namespace blobvk::fem
