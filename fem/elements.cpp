#include "fem/elements.h"

#include "fem/rotation.h"

#include <bitset>
#include <stdexcept>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

Eigen::Vector3d vec(const mesh::Double3& p) { return {p.x, p.y, p.z}; }

// Ds = [x1 - x0, x2 - x0, x3 - x0] as columns.
Eigen::Matrix3d edgeMatrix(const std::vector<mesh::Double3>& x, const std::array<std::uint32_t, 4>& t) {
  const Eigen::Vector3d x0 = vec(x[t[0]]);
  Eigen::Matrix3d D;
  D << vec(x[t[1]]) - x0, vec(x[t[2]]) - x0, vec(x[t[3]]) - x0;
  return D;
}

}  // namespace

void ElementSet::build(const mesh::TetMesh& mesh, const std::vector<Material>& materials) {
  const std::size_t m = mesh.tets.size();
  tets = mesh.tets;
  restInverse.resize(m);
  volume.resize(m);
  lambda.resize(m);
  mu.resize(m);
  density.resize(m);
  quaternion.assign(m, {1, 0, 0, 0});
  rotation.assign(m, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  for (std::size_t e = 0; e < m; ++e) {
    const Eigen::Matrix3d Dm = edgeMatrix(mesh.restPositions, tets[e]);
    Eigen::Map<RowMat3>(restInverse[e].data()) = Dm.inverse();
    volume[e] = Dm.determinant() / 6.0;
    const Material& mat = materials[mesh.regions.empty() ? 0 : mesh.regions[e]];
    lambda[e] = mat.lambda();
    mu[e] = mat.mu();
    density[e] = mat.density;
  }
  // Greedy colouring: the first colour not used yet by any tet sharing a node.
  std::vector<std::bitset<256>> used(mesh.positions.size());
  colours.clear();
  for (std::uint32_t e = 0; e < m; ++e) {
    std::bitset<256> taken;
    for (auto n : tets[e]) taken |= used[n];
    std::size_t c = 0;
    while (c < 256 && taken[c]) ++c;
    if (c == 256) throw std::runtime_error("element colouring needs more than 256 colours (node valence too high)");
    if (c >= colours.size()) colours.resize(c + 1);
    colours[c].push_back(e);
    for (auto n : tets[e]) used[n].set(c);
  }
}

std::vector<double> ElementSet::lumpedMass(std::size_t nodeCount) const {
  std::vector<double> mass(nodeCount, 0.0);
  for (std::size_t e = 0; e < size(); ++e)
    for (auto n : tets[e]) mass[n] += density[e] * volume[e] / 4.0;
  return mass;
}

long long ElementSet::updateRotations(const std::vector<mesh::Double3>& x, int maxIterations) {
  std::vector<int> iterations(size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, size(), 512), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t e = r.begin(); e != r.end(); ++e) {
      const RowMat3 F = edgeMatrix(x, tets[e]) * Eigen::Map<const RowMat3>(restInverse[e].data());
      iterations[e] = extractRotation(F.data(), quaternion[e].data(), maxIterations);
      const Eigen::Quaterniond q(quaternion[e][0], quaternion[e][1], quaternion[e][2], quaternion[e][3]);
      Eigen::Map<RowMat3>(rotation[e].data()) = q.toRotationMatrix();
    }
  });
  long long total = 0;
  for (int i : iterations) total += i;
  return total;
}

double ElementSet::addForcesAndStiffness(const std::vector<mesh::Double3>& x, std::vector<double>& force,
                                         BlockMatrix3* matrix, double scale) const {
  std::vector<double> energy(size());
  for (const auto& colour : colours) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, colour.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t k = r.begin(); k != r.end(); ++k) {
        const std::uint32_t e = colour[k];
        const auto& t = tets[e];
        const Eigen::Map<const RowMat3> Bm(restInverse[e].data());
        const Eigen::Map<const RowMat3> R(rotation[e].data());
        const Eigen::Matrix3d F = edgeMatrix(x, t) * Bm;
        const Eigen::Matrix3d S = R.transpose() * F;
        const Eigen::Matrix3d eps = 0.5 * (S + S.transpose()) - Eigen::Matrix3d::Identity();
        const double tr = eps.trace(), V = volume[e], l = lambda[e], m = mu[e];
        const Eigen::Matrix3d P = R * (2 * m * eps + l * tr * Eigen::Matrix3d::Identity());
        energy[e] = V * (m * eps.squaredNorm() + 0.5 * l * tr * tr);
        // Shape-function gradients: g1..g3 are the rows of Dm^-1, g0 = -(g1 + g2 + g3).
        Eigen::Matrix<double, 3, 4> g;
        g.rightCols<3>() = Bm.transpose();
        g.col(0) = -(g.col(1) + g.col(2) + g.col(3));
        const Eigen::Matrix<double, 3, 4> f = -V * P * g;
        for (int i = 0; i < 4; ++i)
          for (int c = 0; c < 3; ++c) force[3 * std::size_t(t[i]) + std::size_t(c)] += f(c, i);
        if (!matrix) continue;
        // Warped stiffness block (i, j) = V [mu (g_i.g_j) I + mu h_j h_i^T + lambda h_i h_j^T], h = R g.
        const Eigen::Matrix<double, 3, 4> h = R * g;
        const double sv = scale * V;
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) {
            Eigen::Map<RowMat3> B(matrix->block(matrix->slot(e, i, j)));
            B.noalias() += sv * (m * h.col(j) * h.col(i).transpose() + l * h.col(i) * h.col(j).transpose());
            const double d = sv * m * g.col(i).dot(g.col(j));
            B(0, 0) += d;
            B(1, 1) += d;
            B(2, 2) += d;
          }
      }
    });
  }
  double total = 0;
  for (double v : energy) total += v;
  return total;
}

}  // namespace blobvk::fem
