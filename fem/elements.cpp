#include "blobvk/fem/elements.h"

#include "blobvk/fem/kernel_dispatch.h"
#include "blobvk/fem/reserve_touched.h"
#include "blobvk/fem/rotation.h"

#include <chrono>
#include <stdexcept>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

constexpr std::size_t kTetGrain = 1024, kNodeGrain = 512;

template <class Body>
void forEach(std::size_t count, std::size_t grain, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k) body(k);
  });
}

}  // namespace

void ElementSet::build(const mesh::TetMesh& mesh, const std::vector<Material>& materials, double cutRoom) {
  *this = ElementSet();
  reserve(withCutRoom(mesh.tets.size(), cutRoom));  // room for cuts without reallocating
  appendSlots(mesh.tets.size());
  for (std::size_t e = 0; e < mesh.tets.size(); ++e)
    writeTet(std::uint32_t(e), mesh.tets[e], mesh.restPositions, materials[mesh.regions.empty() ? 0 : mesh.regions[e]]);
  filled_ = mesh.tets.size();
  incidence_.build(mesh.positions.size(), tets_, cutRoom);  // one pass, with even spare room per row
}

void ElementSet::appendSlots(std::size_t count) {
  const std::size_t n = tets_.size() + count;
  tets_.resize(n);
  restInverse_.resize(n);
  volume_.resize(n);
  lambda_.resize(n);
  stepLambda_.resize(n);
  mu_.resize(n);
  density_.resize(n);
  quaternion_.resize(n);
  rotatedGradients_.resize(n);
  tetVectors_.resize(n);
  tetDiagonal_.resize(n);
  tetEnergy_.resize(n);
  tetIterations_.resize(n);
}

void ElementSet::setTet(std::uint32_t e, const std::array<std::uint32_t, 4>& nodes, const std::vector<mesh::Double3>& rest,
                        const Material& mat) {
  if (e == tets_.size() && filled_ == e) appendSlots(1);
  if (e < filled_) {
    incidence_.replaceTet(e, tets_[e], nodes);
  } else {
    if (e != filled_) throw std::logic_error("element set: appended slots must be filled in order");
    incidence_.addTet(e, nodes);
    ++filled_;
  }
  writeTet(e, nodes, rest, mat);
}

void ElementSet::writeTet(std::uint32_t e, const std::array<std::uint32_t, 4>& nodes, const std::vector<mesh::Double3>& rest,
                          const Material& mat) {
  tets_[e] = nodes;
  // Dm = [x1 - x0, x2 - x0, x3 - x0] (columns); Dm^-1 = adj(Dm) / det: the rows of Dm^-1 are
  // the cross products of pairs of columns over det (explicit: Eigen's general 3x3 inverse
  // costs ~3x the instructions, which a cut event pays per written tet).
  const mesh::Double3& x0 = rest[nodes[0]];
  double c[3][3];  // c[k] = column k
  for (int k = 0; k < 3; ++k) {
    const mesh::Double3& x = rest[nodes[std::size_t(k + 1)]];
    c[k][0] = x.x - x0.x;
    c[k][1] = x.y - x0.y;
    c[k][2] = x.z - x0.z;
  }
  auto cross = [](const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
  };
  double* inverse = restInverse_[e].data();
  cross(c[1], c[2], inverse);
  cross(c[2], c[0], inverse + 3);
  cross(c[0], c[1], inverse + 6);
  const double det = c[0][0] * inverse[0] + c[0][1] * inverse[1] + c[0][2] * inverse[2];
  for (int i = 0; i < 9; ++i) inverse[i] /= det;
  volume_[e] = det / 6.0;
  lambda_[e] = stepLambda_[e] = mat.lambda();
  mu_[e] = mat.mu();
  density_[e] = mat.density;
  quaternion_[e] = {1, 0, 0, 0};
  rotatedGradients_[e] = {};
  tetVectors_[e] = {};
}

void ElementSet::reserve(std::size_t tets) {
  reserveTouched(tets_, tets);
  reserveTouched(restInverse_, tets);
  reserveTouched(volume_, tets);
  reserveTouched(lambda_, tets);
  reserveTouched(stepLambda_, tets);
  reserveTouched(mu_, tets);
  reserveTouched(density_, tets);
  reserveTouched(quaternion_, tets);
  reserveTouched(rotatedGradients_, tets);
  reserveTouched(tetVectors_, tets);
  reserveTouched(tetDiagonal_, tets);
  reserveTouched(tetEnergy_, tets);
  reserveTouched(tetIterations_, tets);
}

double ElementSet::lumpedMass(std::size_t node) const {
  double m = 0;
  for (const std::uint32_t* p = incidence_.begin(node); p != incidence_.end(node); ++p) {
    const std::uint32_t e = NodeIncidence::tetOf(*p);
    m += density_[e] * volume_[e] / 4.0;
  }
  return m;
}

std::vector<double> ElementSet::lumpedMass() const {
  std::vector<double> mass(nodeCount());
  forEach(mass.size(), kNodeGrain, [&](std::size_t r) { mass[r] = lumpedMass(r); });
  return mass;
}

BLOBVK_FEM_KERNEL void ElementSet::tetPass(std::size_t begin, std::size_t end, const std::vector<mesh::Double3>& x,
                                           int maxIterations, bool withDiagonal) {
  for (std::size_t e = begin; e != end; ++e) {
    const auto& t = tets_[e];
    const double* B = restInverse_[e].data();
    const mesh::Double3& p0 = x[t[0]];
    double D[3][3];  // columns x_k - x_0
    for (int k = 0; k < 3; ++k) {
      const mesh::Double3& p = x[t[std::size_t(k + 1)]];
      D[0][k] = p.x - p0.x;
      D[1][k] = p.y - p0.y;
      D[2][k] = p.z - p0.z;
    }
    double F[9];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) F[a * 3 + b] = D[a][0] * B[b] + D[a][1] * B[3 + b] + D[a][2] * B[6 + b];
    auto& q = quaternion_[e];
    tetIterations_[e] = extractRotation(F, q.data(), maxIterations);
    RowMat3 R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    if (nearlyInverted(F)) invertibleRotation(F, R.data(), q.data());
    const Eigen::Map<const RowMat3> Fm(F);
    const Eigen::Matrix3d S = R.transpose() * Fm;
    const Eigen::Matrix3d eps = 0.5 * (S + S.transpose()) - Eigen::Matrix3d::Identity();
    const double tr = eps.trace(), V = volume_[e], m = mu_[e], l = lambda_[e];
    const VolumeBarrier barrier = volumeBarrier(F);  // inversion safety (rotation.h)
    const double k = kBarrierStiffness * (l + m);
    stepLambda_[e] = l + k * barrier.extraLambda;
    tetEnergy_[e] = V * (m * eps.squaredNorm() + 0.5 * l * tr * tr + k * barrier.energy);
    const Eigen::Matrix3d sigma = 2 * m * eps + l * tr * Eigen::Matrix3d::Identity();
    // f_i = -V R sigma g_i = T h_i with T = -V R sigma R^T and h_i = R g_i; g1..g3 are the rows
    // of Dm^-1 and g0 = -(g1 + g2 + g3), so h0 and f0 follow from the other three.
    const RowMat3 T = -V * R * sigma * R.transpose();
    const Eigen::Map<const RowMat3> Bm(B);
    Eigen::Map<RowMat3> H(rotatedGradients_[e].data());  // row j-1 = h_j
    H.noalias() = Bm * R.transpose();
    double* f = tetVectors_[e].data();
    Eigen::Map<RowMat3>(f + 3).noalias() = H * T;  // rows T h_j (T symmetric)
    if (barrier.pressure != 0) {
      // The barrier's exact force -V k b(J) cof(F) g_j (d det F / dF = cof F), not the
      // corotated R g_j, which points the wrong way for a flattened element.
      const double c = -V * k * barrier.pressure;
      const double cof[9] = {F[4] * F[8] - F[5] * F[7], F[5] * F[6] - F[3] * F[8], F[3] * F[7] - F[4] * F[6],
                             F[2] * F[7] - F[1] * F[8], F[0] * F[8] - F[2] * F[6], F[1] * F[6] - F[0] * F[7],
                             F[1] * F[5] - F[2] * F[4], F[2] * F[3] - F[0] * F[5], F[0] * F[4] - F[1] * F[3]};
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a)
          f[3 + 3 * j + a] += c * (cof[3 * a] * B[3 * j] + cof[3 * a + 1] * B[3 * j + 1] + cof[3 * a + 2] * B[3 * j + 2]);
    }
    for (int c = 0; c < 3; ++c) f[c] = -(f[3 + c] + f[6 + c] + f[9 + c]);
    if (!withDiagonal) continue;
    // Block (i, i) = V [mu |h_i|^2 I + (mu + lambda) h_i h_i^T], stored as xx, yy, zz, xy, xz, yz.
    const double vm = V * m, vml = V * (m + stepLambda_[e]);
    double* d = tetDiagonal_[e].data();
    double h[4][3];
    for (int c = 0; c < 3; ++c) {
      h[1][c] = H(0, c);
      h[2][c] = H(1, c);
      h[3][c] = H(2, c);
      h[0][c] = -(h[1][c] + h[2][c] + h[3][c]);
    }
    for (int i = 0; i < 4; ++i) {
      const double hh = vm * (h[i][0] * h[i][0] + h[i][1] * h[i][1] + h[i][2] * h[i][2]);
      double* block = d + 6 * i;
      for (int c = 0; c < 3; ++c) block[c] = hh + vml * h[i][c] * h[i][c];
      block[3] = vml * h[i][0] * h[i][1];
      block[4] = vml * h[i][0] * h[i][2];
      block[5] = vml * h[i][1] * h[i][2];
    }
  }
}

ElasticPassResult ElementSet::computeForces(const std::vector<mesh::Double3>& x, int maxIterations, double* force,
                                            double* diagonalBlocks) {
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, size(), kTetGrain), [&](const tbb::blocked_range<std::size_t>& r) {
    tetPass(r.begin(), r.end(), x, maxIterations, diagonalBlocks != nullptr);
  });
  lastTetPassMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  gather(force, nullptr, nullptr);
  if (diagonalBlocks) {
    forEach(nodeCount(), kNodeGrain, [&](std::size_t r) {
      double sum[6] = {0, 0, 0, 0, 0, 0};
      for (const std::uint32_t* q = incidence_.begin(r); q != incidence_.end(r); ++q) {
        const double* v = tetDiagonal_[NodeIncidence::tetOf(*q)].data() + 6 * NodeIncidence::cornerOf(*q);
        for (int k = 0; k < 6; ++k) sum[k] += v[k];
      }
      for (int k = 0; k < 6; ++k) diagonalBlocks[6 * r + std::size_t(k)] = sum[k];
    });
  }
  ElasticPassResult result;
  for (std::size_t e = 0; e < size(); ++e) {  // serial: a fixed summation order
    result.energy += tetEnergy_[e];
    result.rotationIterations += tetIterations_[e];
  }
  return result;
}

void ElementSet::gather(double* y, const double* nodeScale, const double* p) const {
  forEach(nodeCount(), kNodeGrain, [&](std::size_t r) {
    if (nodeScale) {
      const double s = nodeScale[r];
      sumCorners(tetVectors_, r, s * p[3 * r], s * p[3 * r + 1], s * p[3 * r + 2], y + 3 * r);
    } else {
      sumCorners(tetVectors_, r, 0.0, 0.0, 0.0, y + 3 * r);
    }
  });
}

// out = (x0, x1, x2) + the 3-vectors perCorner holds for node r's (tet, corner) pairs, in the
// incidence row's order (the fixed summation order that keeps results thread-count independent).
void ElementSet::sumCorners(const std::vector<std::array<double, 12>>& perCorner, std::size_t r, double x0, double x1,
                            double x2, double* out) const {
  for (const std::uint32_t* q = incidence_.begin(r); q != incidence_.end(r); ++q) {
    const double* v = perCorner[NodeIncidence::tetOf(*q)].data() + 3 * NodeIncidence::cornerOf(*q);
    x0 += v[0];
    x1 += v[1];
    x2 += v[2];
  }
  out[0] = x0;
  out[1] = x1;
  out[2] = x2;
}

BLOBVK_FEM_KERNEL void ElementSet::stiffnessPass(std::size_t begin, std::size_t end, const double* p, double scale) {
  for (std::size_t e = begin; e != end; ++e) {
    const auto& t = tets_[e];
    const double* h = rotatedGradients_[e].data();  // h1, h2, h3 (h0 = -(h1 + h2 + h3))
    const double* p0 = p + 3 * std::size_t(t[0]);
    double X[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // sum_j p_j h_j^T = sum_{j>0} (p_j - p_0) h_j^T
    for (int j = 1; j < 4; ++j) {
      const double* pj = p + 3 * std::size_t(t[std::size_t(j)]);
      const double* hj = h + 3 * (j - 1);
      const double d[3] = {pj[0] - p0[0], pj[1] - p0[1], pj[2] - p0[2]};
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) X[a * 3 + b] += d[a] * hj[b];
    }
    const double sm = scale * volume_[e] * mu_[e], sl = scale * volume_[e] * stepLambda_[e];
    const double trace = sl * (X[0] + X[4] + X[8]);
    const double Sxx = 2 * sm * X[0] + trace, Syy = 2 * sm * X[4] + trace, Szz = 2 * sm * X[8] + trace;
    const double Sxy = sm * (X[1] + X[3]), Sxz = sm * (X[2] + X[6]), Syz = sm * (X[5] + X[7]);
    double* out = tetVectors_[e].data();
    for (int j = 1; j < 4; ++j) {
      const double* hj = h + 3 * (j - 1);
      out[3 * j] = Sxx * hj[0] + Sxy * hj[1] + Sxz * hj[2];
      out[3 * j + 1] = Sxy * hj[0] + Syy * hj[1] + Syz * hj[2];
      out[3 * j + 2] = Sxz * hj[0] + Syz * hj[1] + Szz * hj[2];
    }
    for (int c = 0; c < 3; ++c) out[c] = -(out[3 + c] + out[6 + c] + out[9 + c]);
  }
}

void ElementSet::applySystem(const double* p, double* y, const double* nodeScale, double scale) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, size(), kTetGrain), [&](const tbb::blocked_range<std::size_t>& r) {
    stiffnessPass(r.begin(), r.end(), p, scale);
  });
  gather(y, nodeScale, p);
}

}  // namespace blobvk::fem
