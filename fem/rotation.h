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
