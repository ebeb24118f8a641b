#include "blobvk/fem/rotation.h"

#include "blobvk/fem/kernel_dispatch.h"

#include <cmath>

#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace blobvk::fem {

namespace {

// Row-major rotation matrix of the unit quaternion (w, x, y, z).
inline void quaternionToMatrix(const double q[4], double R[9]) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double xx = x * x, yy = y * y, zz = z * z, xy = x * y, xz = x * z, yz = y * z, wx = w * x, wy = w * y, wz = w * z;
  R[0] = 1 - 2 * (yy + zz), R[1] = 2 * (xy - wz), R[2] = 2 * (xz + wy);
  R[3] = 2 * (xy + wz), R[4] = 1 - 2 * (xx + zz), R[5] = 2 * (yz - wx);
  R[6] = 2 * (xz - wy), R[7] = 2 * (yz + wx), R[8] = 1 - 2 * (xx + yy);
}

}  // namespace

// Plain arrays, the symmetric Hessian solved by its adjugate and the exponential map by series
// below 0.05 rad: the warm-started steps of a running body are short, and Eigen's general 3x3
// inverse and a cos/sin pair per step were most of the per-tet cost.
BLOBVK_FEM_KERNEL int extractRotation(const double F[9], double qa[4], int maxIterations, double tolerance) {
  double q[4] = {qa[0], qa[1], qa[2], qa[3]};
  double qn = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(qn >= 0.5)) q[0] = 1, q[1] = q[2] = q[3] = 0, qn = 1;
  double inv = 1 / std::sqrt(qn);
  for (double& v : q) v *= inv;
  int it = 0;
  for (; it < maxIterations; ++it) {
    double R[9];
    quaternionToMatrix(q, R);
    double G[9];  // F R^T
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) G[3 * a + b] = F[3 * a] * R[3 * b] + F[3 * a + 1] * R[3 * b + 1] + F[3 * a + 2] * R[3 * b + 2];
    const double g[3] = {G[7] - G[5], G[2] - G[6], G[3] - G[1]};
    const double trace = G[0] + G[4] + G[8];
    // H = tr(G) I - sym(G): symmetric, entries h00 h01 h02 / h11 h12 / h22.
    const double h00 = trace - G[0], h11 = trace - G[4], h22 = trace - G[8];
    const double h01 = -0.5 * (G[1] + G[3]), h02 = -0.5 * (G[2] + G[6]), h12 = -0.5 * (G[5] + G[7]);
    // Adjugate (cofactors) of the symmetric H; det = h00 c00 + h01 c01 + h02 c02.
    const double c00 = h11 * h22 - h12 * h12, c01 = h02 * h12 - h01 * h22, c02 = h01 * h12 - h02 * h11;
    const double c11 = h00 * h22 - h02 * h02, c12 = h01 * h02 - h00 * h12, c22 = h00 * h11 - h01 * h01;
    // Positive definite by leading minors (scaled): then a Newton step; else the robust step.
    const double scale = std::abs(trace) + 1e-300;
    const double m1 = h00, m2 = c22, m3 = h00 * c00 + h01 * c01 + h02 * c02;
    const double s2 = scale * scale, s3 = s2 * scale;
    const bool newton = m1 > 1e-6 * scale && m2 > 1e-6 * s2 && m3 > 1e-6 * s3;
    double omega[3];
    if (newton) {
      const double id = 1 / m3;
      omega[0] = id * (c00 * g[0] + c01 * g[1] + c02 * g[2]);
      omega[1] = id * (c01 * g[0] + c11 * g[1] + c12 * g[2]);
      omega[2] = id * (c02 * g[0] + c12 * g[1] + c22 * g[2]);
    } else {
      const double k = 1 / (scale + 1e-9);
      omega[0] = k * g[0], omega[1] = k * g[1], omega[2] = k * g[2];
    }
    double w2 = omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2];
    double w = std::sqrt(w2);
    if (!(w > tolerance)) break;  // also stops on NaN input
    if (w > 1.0) {  // never rotate more than 1 rad per iteration
      for (double& o : omega) o /= w;
      w = w2 = 1.0;
    }
    // q <- exp(omega / 2) q. Below 0.05 rad the series are exact to round-off (next terms
    // w^8 / 1e7 and w^8 / 2.6e8 relative).
    double c, sOverW;
    if (w < 0.05) {
      c = 1.0 - w2 / 8.0 * (1.0 - w2 / 48.0 * (1.0 - w2 / 120.0));
      sOverW = 0.5 * (1.0 - w2 / 24.0 * (1.0 - w2 / 80.0 * (1.0 - w2 / 168.0)));
    } else {
      c = std::cos(0.5 * w);
      sOverW = std::sin(0.5 * w) / w;
    }
    const double d[4] = {c, sOverW * omega[0], sOverW * omega[1], sOverW * omega[2]};
    const double r[4] = {d[0] * q[0] - d[1] * q[1] - d[2] * q[2] - d[3] * q[3], d[0] * q[1] + d[1] * q[0] + d[2] * q[3] - d[3] * q[2],
                         d[0] * q[2] - d[1] * q[3] + d[2] * q[0] + d[3] * q[1], d[0] * q[3] + d[1] * q[2] - d[2] * q[1] + d[3] * q[0]};
    inv = 1 / std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    for (int k = 0; k < 4; ++k) q[k] = r[k] * inv;
    // Newton converges quadratically: after a short step on a well-conditioned Hessian, the
    // next step would be far below the tolerance, so the verifying iteration is skipped.
    const bool wellConditioned = m1 > 0.1 * scale && m2 > 0.01 * s2 && m3 > 1e-3 * s3;
    if (newton && wellConditioned && w < 1e-7) {
      ++it;
      break;
    }
  }
  qa[0] = q[0];
  qa[1] = q[1];
  qa[2] = q[2];
  qa[3] = q[3];
  return it;
}

}  // namespace blobvk::fem

namespace blobvk::fem {

namespace {
double determinant(const double F[9]) {
  return F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) + F[2] * (F[3] * F[7] - F[4] * F[6]);
}
}  // namespace

bool nearlyInverted(const double F[9]) { return !(determinant(F) > kNearlyInvertedVolumeRatio); }

VolumeBarrier volumeBarrier(const double F[9]) {
  const double Js = kBarrierVolumeRatio, Jm = kBarrierMinVolumeRatio, J = determinant(F);
  VolumeBarrier b;
  if (!(J < Js)) return b;  // also NaN: no barrier
  auto value = [Js](double x) { return std::log(x / Js) - (x - Js) / Js; };
  auto integral = [Js](double x) { return x * std::log(x / Js) - x + Js - (x - Js) * (x - Js) / (2 * Js); };
  if (J >= Jm) {
    b.pressure = value(J);
    b.extraLambda = Js / J - 1;
    b.energy = integral(J);
  } else {  // linear continuation through J = 0 into inversion
    const double slope = 1 / Jm - 1 / Js;
    b.pressure = value(Jm) + slope * (J - Jm);
    b.extraLambda = Js / Jm - 1;
    b.energy = integral(Jm) + value(Jm) * (J - Jm) + 0.5 * slope * (J - Jm) * (J - Jm);
  }
  return b;
}

void invertibleRotation(const double Fr[9], double Rr[9], double qa[4]) {
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> F(Fr);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(Eigen::Matrix3d(F), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  // Singular values come sorted, largest first: a reflection goes onto the last column (the
  // smallest singular value), which makes U and V proper rotations.
  if (U.determinant() < 0) U.col(2) = -U.col(2);
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  const Eigen::Matrix3d R = U * V.transpose();
  Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> out(Rr);
  out = R;
  Eigen::Quaterniond q(R);
  q.normalize();
  qa[0] = q.w();
  qa[1] = q.x();
  qa[2] = q.y();
  qa[3] = q.z();
}

}  // namespace blobvk::fem
