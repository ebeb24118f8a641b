// The scalar reference evaluator of a Program: one point at a time, in float, in the same order
// of operations as the GLSL shader. Slow and obviously correct; the SIMD and GPU evaluators are
// checked against it.
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

#include <cstdint>

namespace blobvk::blobtree {

struct FieldColour {
  float field = 0.0f;
  glm::vec3 colour{0.0f};
};

// A primitive's RGBA8 colour (PrimitiveRecord::meta.z) as linear RGB in [0, 1].
glm::vec3 unpackColour(std::uint32_t rgba);

// Field at p (inside where >= layout::ISO_VALUE).
float evaluate(const Program& program, const glm::vec3& p);

// The same Program run in double arithmetic (the records stay float): the oracle that tests
// use to separate what compile() changed from float evaluation noise.
double evaluatePrecise(const Program& program, const glm::dvec3& p);

// Field and blended colour at p.
FieldColour evaluateWithColour(const Program& program, const glm::vec3& p);

// Central-difference gradient with step h (world units).
glm::vec3 gradient(const Program& program, const glm::vec3& p, float h = 1e-4f);

// Outward unit normal (-gradient, normalised); (0, 0, 1) where the gradient vanishes.
glm::vec3 normal(const Program& program, const glm::vec3& p, float h = 1e-4f);

// The per-primitive and per-warp formulas, exposed for the SIMD evaluators' tests.
float primitiveField(const Program& program, const layout::PrimitiveRecord& prim, glm::vec3 p);
glm::vec3 applyWarp(const Program& program, const layout::WarpRecord& warp, glm::vec3 p);

// Kernel (1 - dd)^3 for dd < 1, else 0.
inline float wyvill(float dd) {
  const float t = 1.0f - dd;
  return dd < 1.0f ? t * t * t : 0.0f;
}

}  // namespace blobvk::blobtree
