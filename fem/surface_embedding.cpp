#include "blobvk/fem/surface_embedding.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

Eigen::Vector3d vec(const mesh::Double3& p) { return {p.x, p.y, p.z}; }

// A tet's barycentric map at rest: l = inverse * (p - a), weights (1 - sum l, l). Built once per
// tet: the search below tries thousands of tets for a point outside the mesh, and rebuilding
// and inverting the edge matrix for each was most of `blobvk simulate`'s embedding time.
struct BarycentricMap {
  Eigen::Vector3d a;
  Eigen::Matrix3d inverse;
};

BarycentricMap barycentricMap(const mesh::TetMesh& m, const std::array<std::uint32_t, 4>& t) {
  const Eigen::Vector3d a = vec(m.restPositions[t[0]]);
  Eigen::Matrix3d D;
  D << vec(m.restPositions[t[1]]) - a, vec(m.restPositions[t[2]]) - a, vec(m.restPositions[t[3]]) - a;
  return {a, D.inverse()};
}

// Barycentric coordinates of p in the tet of `map`.
std::array<double, 4> barycentric(const BarycentricMap& map, const Eigen::Vector3d& p) {
  const Eigen::Vector3d l = map.inverse * (p - map.a);
  return {1 - l.sum(), l.x(), l.y(), l.z()};
}

}  // namespace

SurfaceEmbedding identityEmbedding(std::size_t count) {
  SurfaceEmbedding e;
  e.nodes.resize(count);
  e.weights.assign(count, {1, 0, 0, 0});
  for (std::size_t i = 0; i < count; ++i) e.nodes[i] = {std::uint32_t(i), std::uint32_t(i), std::uint32_t(i), std::uint32_t(i)};
  return e;
}

SurfaceEmbedding embedPoints(const mesh::TetMesh& m, std::span<const mesh::Float3> points) {
  if (m.tets.empty()) throw std::invalid_argument("embedPoints: empty tet mesh");
  // Uniform grid of tet bounding boxes, cell size ~ the mean tet extent.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  double meanExtent = 0;
  for (const auto& t : m.tets) {
    Eigen::Vector3d tlo = vec(m.restPositions[t[0]]), thi = tlo;
    for (int k = 1; k < 4; ++k) {
      tlo = tlo.cwiseMin(vec(m.restPositions[t[k]]));
      thi = thi.cwiseMax(vec(m.restPositions[t[k]]));
    }
    lo = lo.cwiseMin(tlo);
    hi = hi.cwiseMax(thi);
    meanExtent += (thi - tlo).maxCoeff();
  }
  const double cell = std::max(meanExtent / double(m.tets.size()), 1e-12);
  const Eigen::Vector3i dims = (((hi - lo) / cell).array().floor().cast<int>() + 1).matrix();
  auto cellOf = [&](const Eigen::Vector3d& p) {
    return ((p - lo) / cell).array().floor().cast<int>().cwiseMax(0).cwiseMin(dims.array() - 1).matrix().eval();
  };
  auto key = [&](const Eigen::Vector3i& c) { return (std::int64_t(c.z()) * dims.y() + c.y()) * dims.x() + c.x(); };
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> bins;
  for (std::uint32_t ti = 0; ti < m.tets.size(); ++ti) {
    const auto& t = m.tets[ti];
    Eigen::Vector3d tlo = vec(m.restPositions[t[0]]), thi = tlo;
    for (int k = 1; k < 4; ++k) {
      tlo = tlo.cwiseMin(vec(m.restPositions[t[k]]));
      thi = thi.cwiseMax(vec(m.restPositions[t[k]]));
    }
    const Eigen::Vector3i a = cellOf(tlo), b = cellOf(thi);
    for (int z = a.z(); z <= b.z(); ++z)
      for (int y = a.y(); y <= b.y(); ++y)
        for (int x = a.x(); x <= b.x(); ++x) bins[key({x, y, z})].push_back(ti);
  }

  std::vector<BarycentricMap> maps(m.tets.size());
  tbb::parallel_for(std::size_t(0), m.tets.size(), [&](std::size_t ti) { maps[ti] = barycentricMap(m, m.tets[ti]); });

  SurfaceEmbedding e;
  e.nodes.resize(points.size());
  e.weights.resize(points.size());
  tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t i) {
    const Eigen::Vector3d p(points[i].x, points[i].y, points[i].z);
    const Eigen::Vector3i c = cellOf(p);
    // Search growing shells of cells: the first tet containing p wins; otherwise the tet whose
    // barycentric coordinates are least negative.
    std::uint32_t best = UINT32_MAX;
    double bestScore = -std::numeric_limits<double>::max();
    std::array<double, 4> bestW{};
    for (int r = 0; r <= 3 && bestScore < -1e-9; ++r) {
      for (int z = c.z() - r; z <= c.z() + r; ++z)
        for (int y = c.y() - r; y <= c.y() + r; ++y)
          for (int x = c.x() - r; x <= c.x() + r; ++x) {
            if (std::max({std::abs(x - c.x()), std::abs(y - c.y()), std::abs(z - c.z())}) != r) continue;
            if (x < 0 || y < 0 || z < 0 || x >= dims.x() || y >= dims.y() || z >= dims.z()) continue;
            auto it = bins.find(key({x, y, z}));
            if (it == bins.end()) continue;
            for (auto ti : it->second) {
              const auto w = barycentric(maps[ti], p);
              const double score = *std::min_element(w.begin(), w.end());
              if (score > bestScore) {
                bestScore = score;
                best = ti;
                bestW = w;
              }
            }
          }
    }
    if (best == UINT32_MAX) {  // far from the mesh: brute force
      for (std::uint32_t ti = 0; ti < m.tets.size(); ++ti) {
        const auto w = barycentric(maps[ti], p);
        const double score = *std::min_element(w.begin(), w.end());
        if (score > bestScore) {
          bestScore = score;
          best = ti;
          bestW = w;
        }
      }
    }
    e.nodes[i] = m.tets[best];
    e.weights[i] = bestW;
  });
  return e;
}

void computeNormals(mesh::TriMesh& s) {
  std::vector<Eigen::Vector3d> n(s.positions.size(), Eigen::Vector3d::Zero());
  auto p = [&](std::uint32_t i) { return Eigen::Vector3d(s.positions[i].x, s.positions[i].y, s.positions[i].z); };
  for (const auto& t : s.triangles) {
    const Eigen::Vector3d fn = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));  // |fn| = 2 area
    for (auto v : t) n[v] += fn;
  }
  s.normals.resize(s.positions.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    const double len = n[i].norm();
    const Eigen::Vector3d u = len > 0 ? Eigen::Vector3d(n[i] / len) : Eigen::Vector3d(0, 0, 1);
    s.normals[i] = {float(u.x()), float(u.y()), float(u.z())};
  }
}

void applyEmbedding(const SurfaceEmbedding& e, const std::vector<mesh::Double3>& x, mesh::TriMesh& s) {
  if (e.size() != s.positions.size()) throw std::invalid_argument("applyEmbedding: embedding and surface sizes differ");
  for (std::size_t i = 0; i < e.size(); ++i) {
    double px = 0, py = 0, pz = 0;
    for (int k = 0; k < 4; ++k) {
      const auto& q = x[e.nodes[i][k]];
      px += e.weights[i][k] * q.x;
      py += e.weights[i][k] * q.y;
      pz += e.weights[i][k] * q.z;
    }
    s.positions[i] = {float(px), float(py), float(pz)};
  }
  computeNormals(s);
}

mesh::TriMesh boundarySurface(const mesh::TetMesh& m) {
  mesh::TriMesh s;
  s.positions.resize(m.positions.size());
  for (std::size_t i = 0; i < m.positions.size(); ++i)
    s.positions[i] = {float(m.positions[i].x), float(m.positions[i].y), float(m.positions[i].z)};
  s.triangles.assign(m.boundaryFaces.begin(), m.boundaryFaces.end());
  computeNormals(s);
  return s;
}

}  // namespace blobvk::fem
