// Interval bounds of a Program's field over many axis-aligned boxes (the MPU polygonizer's
// sparse field cache halves each kept MPU level by level and bounds every box of a level). As
// conservative as fieldBounds (field_bounds.h), cheaper per box.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/field_bounds.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace blobvk::cpu {

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
