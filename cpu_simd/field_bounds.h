// Conservative bounds of a Program's field over an axis-aligned box, for the MPU polygonizer's
// early discard. The code is run once over the box instead of a point: skips whose box misses
// the query box jump exactly as they would for every point inside it, primitives contribute an
// interval from the distance between the query box (mapped to the unit frame) and the skeleton's
// box, operators combine intervals. Every step rounds outwards, so a box reported all-outside
// (hi < iso) or all-inside (lo >= iso) really has no surface: unlike the thesis' 8-corner test,
// it never drops a primitive smaller than the box.
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace blobvk::cpu {

struct FieldInterval {
  double lo = 0.0, hi = 0.0;
};

// A box of point-register coordinates in double; may be infinite (unbounded warps).
struct BoundsBox {
  glm::dvec3 lo, hi;
  bool finite() const;
  static BoundsBox everything();
};

// The box grown by a margin larger than float rounding of coordinates of its magnitude.
BoundsBox padBounds(const BoundsBox& box);

// Conservative box of warp(p) for every p in `box` (padded; infinite for bends).
BoundsBox warpBounds(const blobtree::Program& program, const layout::WarpRecord& warp,
                     const BoundsBox& box);

// True when the reference's float evaluation of `prim` is exactly 0 at every point of `box`
// (in the coordinates of the primitive's point register): the skeleton is farther than the
// support radius, with margins well above float rounding.
bool primitiveIsZeroOver(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                         const BoundsBox& box);

// Interval containing blobtree::evaluate(program, p) for every p in [lo, hi] (float rounding
// included by a small outward margin).
FieldInterval fieldBounds(const blobtree::Program& program, const glm::dvec3& lo,
                          const glm::dvec3& hi);

}  // namespace blobvk::cpu
