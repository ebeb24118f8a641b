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

// fieldBounds for many boxes of one Program, cheaper per box: per primitive, the distance at
// the box's centre (1-Lipschitz, so within the radius of the box's image in the unit frame) and
// the distance between the box's image and the skeleton's box, with the per-size parts (radius,
// image half extents) cached while consecutive boxes keep one size. Programs with warps take
// fieldBounds itself. The interval is as conservative as fieldBounds's.
class BlockBounds {
 public:
  // Before the first box of a Program; every box asked for afterwards lies in the region (the
  // rounding margins are sized for its coordinates; a box outside takes fieldBounds).
  void reset(const blobtree::Program& program, const glm::dvec3& regionLo, const glm::dvec3& regionHi);
  FieldInterval operator()(const glm::dvec3& lo, const glm::dvec3& hi);
  // Many boxes of one size at once, centred at (cx, cy, cz)[i] with `halfExtent` (at least each
  // box's): the same bound per box, one instruction at a time over the batch.
  void operator()(std::size_t n, const double* cx, const double* cy, const double* cz,
                  const glm::dvec3& halfExtent, double* lo, double* hi);

 private:
  struct Prim {
    glm::dvec3 skeletonLo{0.0}, skeletonHi{0.0};
    bool matrix = false;
    glm::dvec3 rows[3]{}, offset{0.0};
    double offsetMax = 0.0, rowAbsMax = 1.0;
    double reach = 0.0;          // the cached size's image radius, plus rounding margins
    glm::dvec3 localHalf{0.0};   // half extents of the image's bounding box, plus margins
  };
  void cacheSize(const glm::dvec3& halfExtent);
  const blobtree::Program* program_ = nullptr;
  bool general_ = false;  // warps: fieldBounds itself
  bool skips_ = false;
  glm::dvec3 regionLo_{0.0}, regionHi_{0.0};
  double regionMax_ = 0.0;
  std::vector<Prim> prims_;  // per instruction (OP_PRIM ones)
  std::size_t registers_ = 1;
  std::vector<double> regLo_, regHi_;  // the batch's interval registers, [register][box]
  std::vector<std::uint8_t> skipModes_;  // per open skip, per box: inside, straddling, disjoint
  glm::dvec3 halfExtent_{-1.0};
};

}  // namespace blobvk::cpu
