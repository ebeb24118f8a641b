// Rotation of a deformation gradient F (row-major 3x3), warm-started from the previous quaternion.
// It maximizes tr(R^T F) over rotations: Newton steps on the rotation manifold where the local
// Hessian tr(G) I - sym(G) (G = F R^T) is positive definite, and the robust step of Mueller et
// al. 2016 ("A robust method to extract the rotational part of deformations") elsewhere. The
// maximizer is the polar rotation U V^T for det F > 0 and, for inverted elements, the
// sign-fixed U diag(1,1,-1) V^T: always a proper rotation, continuous through inversion.
#pragma once

namespace blobvk::fem {

// q (w, x, y, z) is read as the warm start and overwritten. Returns the iterations used. Stops
// when a step is shorter than `tolerance` (radians), or right after a Newton step shorter than
// 1e-7 on a well-conditioned Hessian (quadratic convergence: the next one would be ~1e-14).
int extractRotation(const double F[9], double q[4], int maxIterations = 30, double tolerance = 1e-13);

}  // namespace blobvk::fem

namespace blobvk::fem {

// Below this det F (volume ratio) an element counts as nearly inverted: its rotation comes from
// an SVD with Irving et al.'s sign convention (2004, "Invertible finite elements"), not from the
// warm-started iteration, which can stall near the flat configuration where R is ill-defined.
inline constexpr double kNearlyInvertedVolumeRatio = 0.25;
bool nearlyInverted(const double F[9]);
// F = U diag(s) V^T with U, V proper rotations and the reflection, if any, on the smallest
// singular value; returns R = U V^T (row-major) and writes it into q (w, x, y, z).
void invertibleRotation(const double F[9], double R[9], double q[4]);

// Volume barrier of the inversion-safe material. The linear corotational pressure lambda tr(eps)
// is blind to the volume ratio J = det F (a tet squeezed flat while bulging sideways has
// tr(eps) >= 0), so a soft body under a strong load can be pushed flat and through. Below
// J = kBarrierVolumeRatio the stress gains a pressure k b(J) I with
// b(J) = ln(J / Js) - (J - Js) / Js (0 with zero slope at Js, -> -infinity as J -> 0), continued
// linearly below kBarrierMinVolumeRatio so that inverted elements (J <= 0) are pushed back with a
// finite force; k = kBarrierStiffness (lambda + mu). Its force is the exact -V k b(J) cof(F) g
// (elements.cpp); the implicit system only gets k (Js / J - 1) as extra lambda, an
// approximation of the barrier's tangent that limits k: 3x already diverges on the peanut test.
inline constexpr double kBarrierVolumeRatio = 0.6, kBarrierMinVolumeRatio = 0.05, kBarrierStiffness = 1.0;
struct VolumeBarrier {
  double pressure = 0;      // b(J), times k gives the added stress (negative: pushes apart)
  double extraLambda = 0;   // J b'(J), times k gives the added lambda of the implicit system
  double energy = 0;        // integral of b from Js to J (per unit rest volume, times k)
};
VolumeBarrier volumeBarrier(const double F[9]);

}  // namespace blobvk::fem
