#include "test_helpers.h"

#include "blobvk/cutting/vec.h"

#include <cmath>

namespace blobvk::cutting::test {

mesh::TetMesh cubeMesh(int n, double h) {
  mesh::TetMesh m;
  auto id = [n](int x, int y, int z) { return std::uint32_t((z * (n + 1) + y) * (n + 1) + x); };
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) m.positions.push_back({x * h, y * h, z * h});
  m.restPositions = m.positions;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        // L/R = x, B/T = y, N/F = z (thesis Tetrahedralizer.cl naming).
        const std::uint32_t LBN = id(x, y, z), RBN = id(x + 1, y, z), LTN = id(x, y + 1, z), RTN = id(x + 1, y + 1, z);
        const std::uint32_t LBF = id(x, y, z + 1), RBF = id(x + 1, y, z + 1), LTF = id(x, y + 1, z + 1),
                            RTF = id(x + 1, y + 1, z + 1);
        const std::array<std::array<std::uint32_t, 4>, 6> tets{{{LBN, LTN, RBN, LBF},
                                                                 {RTN, LTN, LBF, RBN},
                                                                 {RTN, LTN, LTF, LBF},
                                                                 {RTN, RBN, LBF, RBF},
                                                                 {RTN, LBF, LTF, RBF},
                                                                 {RTN, LTF, RTF, RBF}}};
        for (auto t : tets) {
          const auto& p = m.positions;
          if (tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
        }
      }
  return m;
}

mesh::TetMesh singleTet(Double3 a, Double3 b, Double3 c, Double3 d) {
  mesh::TetMesh m;
  m.positions = {a, b, c, d};
  if (tetVolume(a, b, c, d) < 0) std::swap(m.positions[2], m.positions[3]);
  m.restPositions = m.positions;
  m.tets = {{0, 1, 2, 3}};
  return m;
}

mesh::TetMesh randomTet(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), s(0.5, 2.0), off(-100.0, 100.0);
  // Random rotation from a random unit quaternion.
  double q[4];
  double norm = 0;
  do {
    norm = 0;
    for (double& x : q) {
      x = u(rng);
      norm += x * x;
    }
  } while (norm > 1.0 || norm < 1e-3);
  for (double& x : q) x /= std::sqrt(norm);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                          {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                          {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  const double sx = s(rng), sy = s(rng), sz = s(rng);
  const Double3 t{off(rng), off(rng), off(rng)};
  const Double3 regular[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  Double3 p[4];
  for (int i = 0; i < 4; ++i) {
    const Double3 r{regular[i].x * sx, regular[i].y * sy, regular[i].z * sz};
    p[i] = Double3{R[0][0] * r.x + R[0][1] * r.y + R[0][2] * r.z, R[1][0] * r.x + R[1][1] * r.y + R[1][2] * r.z,
                   R[2][0] * r.x + R[2][1] * r.y + R[2][2] * r.z} +
           t;
  }
  return singleTet(p[0], p[1], p[2], p[3]);
}

BladePath squareSweep(Double3 centre, Double3 u, Double3 v, double half) {
  BladePath path;
  path.keyframes.push_back({0.0, centre - u * half - v * half, centre - u * half + v * half});
  path.keyframes.push_back({1.0, centre + u * half - v * half, centre + u * half + v * half});
  return path;
}

std::vector<Triangle> squareTriangles(Double3 centre, Double3 u, Double3 v, double half) {
  const BladePath p = squareSweep(centre, u, v, half);
  return sweptTriangles(p.keyframes[0], p.keyframes[1]);
}

double relativeDifference(double a, double b) { return std::fabs(a - b) / std::max(std::fabs(a), std::fabs(b)); }

}  // namespace blobvk::cutting::test
