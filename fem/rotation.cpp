#include "blobvk/fem/rotation.h"

#include "blobvk/fem/kernel_dispatch.h"

#include <cmath>

#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace blobvk::fem {

BLOBVK_FEM_KERNEL int extractRotation(const double Fr[9], double qa[4], int maxIterations, double tolerance) {
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> F(Fr);
  Eigen::Quaterniond q(qa[0], qa[1], qa[2], qa[3]);
  if (q.squaredNorm() < 0.5) q = Eigen::Quaterniond::Identity();
  q.normalize();
  int it = 0;
  for (; it < maxIterations; ++it) {
    const Eigen::Matrix3d R = q.toRotationMatrix();
    const Eigen::Matrix3d G = F * R.transpose();
    const Eigen::Vector3d g(G(2, 1) - G(1, 2), G(0, 2) - G(2, 0), G(1, 0) - G(0, 1));
    const double trace = G.trace();
    const Eigen::Matrix3d H = trace * Eigen::Matrix3d::Identity() - 0.5 * (G + G.transpose());
    // Positive definite by leading minors (scaled): then a Newton step; else the robust step.
    const double scale = std::abs(trace) + 1e-300;
    const double m1 = H(0, 0), m2 = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0), m3 = H.determinant();
    Eigen::Vector3d omega;
    const bool newton = m1 > 1e-6 * scale && m2 > 1e-6 * scale * scale && m3 > 1e-6 * scale * scale * scale;
    if (newton)
      omega = H.inverse() * g;
    else
      omega = g / (scale + 1e-9);
    double w = omega.norm();
    if (!(w > tolerance)) break;  // also stops on NaN input
    if (w > 1.0) {  // never rotate more than 1 rad per iteration
      omega /= w;
      w = 1.0;
    }
    // q <- exp(omega / 2) q; small angles use the series (exact to round-off below 1e-4 rad).
    const double c = w < 1e-4 ? 1.0 - w * w / 8.0 : std::cos(0.5 * w);
    const double sOverW = w < 1e-4 ? 0.5 - w * w / 48.0 : std::sin(0.5 * w) / w;
    q = Eigen::Quaterniond(c, sOverW * omega.x(), sOverW * omega.y(), sOverW * omega.z()) * q;
    q.normalize();
    // Newton converges quadratically: after a short step on a well-conditioned Hessian, the
    // next step would be far below the tolerance, so the verifying iteration is skipped.
    const bool wellConditioned = m1 > 0.1 * scale && m2 > 0.01 * scale * scale && m3 > 1e-3 * scale * scale * scale;
    if (newton && wellConditioned && w < 1e-7) {
      ++it;
      break;
    }
  }
  qa[0] = q.w();
  qa[1] = q.x();
  qa[2] = q.y();
  qa[3] = q.z();
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
