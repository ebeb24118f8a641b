// Analytic gradients of a Program: one pass per point gives the field, its exact gradient (and
// the colour), where central differences need six more passes. Every primitive differentiates
// its squared distance; operators apply the sum, product and chain rules, and min/max-like
// operators (union, intersection, difference) take the gradient of the operand whose value they
// keep, with the same comparison the colour uses, so ties resolve the same way everywhere; warps
// carry a 3x3 Jacobian per point register (chain rule through the warp and its matrix).
// The AVX evaluators (cpu_simd/) repeat these float operations in the same order.
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

namespace blobvk::blobtree {

struct FieldGradient {
  float field = 0.0f;
  glm::vec3 gradient{0.0f};  // d field / d p, in world units
  glm::vec3 colour{0.0f};    // only from evaluateGradientColour
};

// Row-major: m[i][j] = d out_i / d in_j.
struct Jacobian3 {
  float m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
};

FieldGradient evaluateGradient(const Program& program, const glm::vec3& p);
FieldGradient evaluateGradientColour(const Program& program, const glm::vec3& p);

// Outward unit normal from a gradient: -g / |g|, (0, 0, 1) where it vanishes (as normal()).
glm::vec3 outwardNormal(const glm::vec3& gradient);
// outwardNormal(evaluateGradient(program, p).gradient).
glm::vec3 analyticNormal(const Program& program, const glm::vec3& p);

// The warp (with its matrix) at p, and `jacobian` replaced by J_warp(p) * jacobian: for the SIMD
// evaluators, which call it per lane as they call applyWarp.
glm::vec3 applyWarpJacobian(const Program& program, const layout::WarpRecord& warp, glm::vec3 p, Jacobian3& jacobian);
// pow(max(base, 0), e) and its derivative in base (0 where base <= 0), as OP_POW differentiates.
float powDerivative(float base, float exponent, float& derivative);

}  // namespace blobvk::blobtree
