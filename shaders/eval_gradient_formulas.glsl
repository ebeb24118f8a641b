// The analytic-gradient formulas of blobtree/evaluate_gradient.cpp as pure functions of record
// values, shared by the gradient interpreter (eval_gradient.glsl, which loads the values from the
// Program's buffers) and the specialised gradient (vk/eval/gradient_codegen.cpp, which passes
// literals). One copy of each formula keeps both computing the same float operations in the same
// order, so their normals are bit for bit equal; keep them in step with evaluate_gradient.cpp.
//
// Everything the results depend on is `precise`: they leave through out parameters, which a
// function's precise return value does not reach (test_no_contraction audits the SPIR-V).
// Include after eval_formulas.glsl.
#ifndef BLOBVK_EVAL_GRADIENT_FORMULAS_GLSL
#define BLOBVK_EVAL_GRADIENT_FORMULAS_GLSL

#include "program_layout.h"

// M^T g for a matrix record's rows.
precise vec3 transposeTimesRows(vec4 r0, vec4 r1, vec4 r2, vec3 g) {
  return vec3(r0.x * g.x + r1.x * g.y + r2.x * g.z, r0.y * g.x + r1.y * g.y + r2.y * g.z,
              r0.z * g.x + r1.z * g.y + r2.z * g.z);
}

// Row-major Jacobians as three rows (j[i] = d out_i / d in).
precise vec3 jacobianTransposeTimes(vec3 j0, vec3 j1, vec3 j2, vec3 g) {
  return vec3(j0.x * g.x + j1.x * g.y + j2.x * g.z, j0.y * g.x + j1.y * g.y + j2.y * g.z,
              j0.z * g.x + j1.z * g.y + j2.z * g.z);
}

#ifndef GRADIENT_FORMULA_HAS_PRIM
#define GRADIENT_FORMULA_HAS_PRIM(t) true
#endif

// Field of a primitive of `type` at p (in its local frame: the matrix already applied) and its
// gradient in that frame in `grad`; p0, p1, p2 its record's skeleton words.
precise float primitiveGradientOf(uint type, vec3 p, vec4 p0, vec4 p1, vec4 p2, out vec3 grad) {
#include "eval_gradient_primitive_body.glsl"
}

#ifndef GRADIENT_FORMULA_HAS_WARP
#define GRADIENT_FORMULA_HAS_WARP(t) true
#endif

// Warp of `type` (axes a, b, parameters `params`) at p (in its local frame) whose Jacobian
// with respect to the world point is `jin` (columns = rows of J): returns the warped point,
// (j0, j1, j2) the rows of J_warp(p) * J. `zero` is 0.0, passed in so that generated code with
// literal axes can keep NIR from folding the products with the identity's zeros
// (vk/eval/gradient_codegen.cpp).
precise vec3 warpJacobianOf(uint type, uint a, uint b, vec4 params, vec3 p, mat3 jin, float zero, out vec3 j0,
                            out vec3 j1, out vec3 j2) {
  float k = params.x;
  precise mat3 w = mat3(1.0, zero, zero, zero, 1.0, zero, zero, zero, 1.0);  // w[col][row]
  if (GRADIENT_FORMULA_HAS_WARP(WARP_TWIST) && type == WARP_TWIST) {
    uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    p = warpTwist(p, a, k);
    float theta = k * p[a];
    float c = cos(theta), s = sin(theta);
    w[u][u] = c;
    w[v][u] = -s;
    w[a][u] = -k * p[v];
    w[u][v] = s;
    w[v][v] = c;
    w[a][v] = k * p[u];
  } else if (GRADIENT_FORMULA_HAS_WARP(WARP_TAPER) && type == WARP_TAPER) {
    w[b][b] = 1.0 + k * p[a];
    w[a][b] = k * p[b];
    p = warpTaper(p, a, b, k);
  } else if (GRADIENT_FORMULA_HAS_WARP(WARP_SHEAR) && type == WARP_SHEAR) {
    p = warpShear(p, a, b, k);
    w[b][a] = k;
  } else if (GRADIENT_FORMULA_HAS_WARP(WARP_BEND) && type == WARP_BEND && k != 0.0) {
    float y = p[a], z = p[b];
    float yc = clamp(y, params.z, params.w);
    float theta = k * (yc - params.y);
    float c = cos(theta), s = sin(theta);
    float invK = 1.0 / k;
    float beyond = y - yc;
    p = warpBend(p, a, b, params);
    bool bent = y > params.z && y < params.w;
    float dTheta = bent ? k : 0.0, dBeyond = bent ? 0.0 : 1.0;
    w[a][a] = -c * dTheta * (z - invK) - s * dTheta * beyond + c * dBeyond;
    w[a][b] = -s * dTheta * (z - invK) + c * dTheta * beyond + s * dBeyond;
    w[b][a] = -s;
    w[b][b] = c;
  }
  precise mat3 jout = transpose(w * jin);
  j0 = jout[0];
  j1 = jout[1];
  j2 = jout[2];
  return p;
}

#endif  // BLOBVK_EVAL_GRADIENT_FORMULAS_GLSL
