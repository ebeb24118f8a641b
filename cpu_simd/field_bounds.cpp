// See field_bounds.h. Boxes are tracked in double and padded by a relative margin wherever a
// float computation of the reference could land outside the exact-arithmetic value.
#include "blobvk/cpu_simd/field_bounds.h"

#include "blobvk/cpu_simd/field_bounds_detail.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace blobvk::cpu {
namespace bounds_detail {
namespace {

// Centre and radius (farthest point from the centre) of a box's image in the primitive's unit
// frame, grown by more than the reference's float rounding of the transform.
void localBall(const blobtree::Program& program, const layout::PrimitiveRecord& prim, const Box& world,
               glm::dvec3& centre, double& radius) {
  const glm::dvec3 c = (world.lo + world.hi) * 0.5, e = (world.hi - world.lo) * 0.5;
  if (prim.meta.y == 0u) {
    centre = c;
    radius = glm::length(e) + 1e-5 * (1.0 + std::max({std::abs(c.x), std::abs(c.y), std::abs(c.z)}) +
                                      glm::length(e));
    return;
  }
  const layout::MatrixRecord& m = program.matrices[prim.meta.y];
  const glm::dvec3 rows[3] = {xyz(m.r0), xyz(m.r1), xyz(m.r2)};
  const double w[3] = {m.r0.w, m.r1.w, m.r2.w};
  double magnitude = 0.0;
  for (int r = 0; r < 3; ++r) {
    centre[r] = glm::dot(rows[r], c) + w[r];
    magnitude = std::max(magnitude, std::abs(w[r]) + glm::dot(glm::abs(rows[r]), glm::abs(c) + e));
  }
  // The image of the box is a parallelepiped centred on the image of c; its farthest points
  // are corners, and opposite corners are equally far: four sign patterns cover them.
  radius = 0.0;
  for (const glm::dvec3 s : {glm::dvec3(1, 1, 1), glm::dvec3(1, 1, -1), glm::dvec3(1, -1, 1),
                             glm::dvec3(1, -1, -1)}) {
    const glm::dvec3 v = s * e;
    radius = std::max(radius, glm::length(glm::dvec3(glm::dot(rows[0], v), glm::dot(rows[1], v),
                                                     glm::dot(rows[2], v))));
  }
  radius += 1e-5 * (1.0 + magnitude);
}

}  // namespace

// The kernel is decreasing in the distance d to the skeleton. Over the box, d lies within
// [D(c) - r, D(c) + r] around the ball's centre c (1-Lipschitz), and is at least the distance
// between the box and the skeleton's bounding box; both bounds hold, so the tighter is kept.
FieldInterval primitiveBounds(const blobtree::Program& program,
                              const layout::PrimitiveRecord& prim, const Box& world) {
  const double scale = prim.meta.x == layout::PRIM_QUADRIC ? double(prim.p0.w) : 1.0;
  const FieldInterval any{std::min(0.0, scale), std::max(0.0, scale)};
  if (prim.meta.x > layout::PRIM_QUADRIC) return {0.0, 0.0};
  if (!world.finite()) return any;
  glm::dvec3 centre;
  double radius = 0.0;
  localBall(program, prim, world, centre, radius);
  // Float distance arithmetic in the unit frame: the same absolute pad as the skeleton box's.
  const double distance = skeletonDistance(prim, centre);
  const double near = std::max(distance - radius - 1e-4, 0.0), far = distance + radius + 1e-4;
  double ddMin = near * near;
  if (ddMin >= 1.0) return {0.0, 0.0};
  {
    // The box-to-box distance is the tighter bound beside a skeleton's flat sides and corners.
    const Box local = prim.meta.y != 0u ? transform(program.matrices[prim.meta.y], world) : world;
    if (!local.finite()) return any;
    glm::dvec3 lo, hi;
    skeletonBox(prim, lo, hi);
    ddMin = std::max(ddMin, boxDistance2(local, lo, hi));
    if (ddMin >= 1.0) return {0.0, 0.0};
  }
  const double tHi = 1.0 - ddMin, tLo = std::max(1.0 - far * far, 0.0);
  if (prim.meta.x == layout::PRIM_QUADRIC) {
    const double a = scale * tLo * tLo, b = scale * tHi * tHi;
    return {std::min(a, b), std::max(a, b)};
  }
  return {tLo * tLo * tLo, tHi * tHi * tHi};
}

Box warpBox(const blobtree::Program& program, const layout::WarpRecord& warp, Box b) {
  if (warp.meta.w != 0u) b = transform(program.matrices[warp.meta.w], b);
  if (!b.finite()) return b;
  const unsigned a = warp.meta.y, c = warp.meta.z;
  const double k = warp.params.x;
  switch (warp.meta.x) {
    case layout::WARP_TWIST: {
      // A rotation about axis a keeps the coordinate along a and the distance from the axis.
      const unsigned u = (a + 1u) % 3u, v = (a + 2u) % 3u;
      const double mu = std::max(std::abs(b.lo[u]), std::abs(b.hi[u]));
      const double mv = std::max(std::abs(b.lo[v]), std::abs(b.hi[v]));
      const double r = std::sqrt(mu * mu + mv * mv);
      b.lo[u] = b.lo[v] = -r;
      b.hi[u] = b.hi[v] = r;
      return pad(b);
    }
    case layout::WARP_TAPER: {
      const FieldInterval f = mul(FieldInterval{b.lo[c], b.hi[c]},
                                  FieldInterval{1.0 + std::min(k * b.lo[a], k * b.hi[a]),
                                                1.0 + std::max(k * b.lo[a], k * b.hi[a])});
      b.lo[c] = f.lo, b.hi[c] = f.hi;
      return pad(b);
    }
    case layout::WARP_SHEAR: {
      const FieldInterval s = mul(FieldInterval{b.lo[c], b.hi[c]}, k);
      b.lo[a] += s.lo, b.hi[a] += s.hi;
      return pad(b);
    }
    default:  // bend: not worth a tight bound
      return Box::everything();
  }
}

}  // namespace bounds_detail

using namespace bounds_detail;

bool BoundsBox::finite() const {
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a])) return false;
  return true;
}

BoundsBox BoundsBox::everything() { return {glm::dvec3(-kInf), glm::dvec3(kInf)}; }

BoundsBox padBounds(const BoundsBox& box) { return pad(box); }

BoundsBox warpBounds(const blobtree::Program& program, const layout::WarpRecord& warp,
                     const BoundsBox& box) {
  return warpBox(program, warp, box);
}

bool primitiveIsZeroOver(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                         const BoundsBox& box) {
  if (prim.meta.x > layout::PRIM_QUADRIC) return true;  // the reference returns 0 for these
  const Box local = prim.meta.y != 0u ? transform(program.matrices[prim.meta.y], box) : pad(box);
  if (!local.finite()) return false;
  glm::dvec3 lo, hi;
  skeletonBox(prim, lo, hi);
  // The kernel is 0 exactly when the float dd >= 1; a 1e-3 margin on top of the padded boxes
  // keeps rounding of dd from ever landing below 1.
  return boxDistance2(local, lo, hi) >= 1.001;
}

FieldInterval fieldBounds(const blobtree::Program& program, const glm::dvec3& lo,
                          const glm::dvec3& hi) {
  return runBounds(program, pad(Box{lo, hi}),
                   [&](std::size_t, const layout::PrimitiveRecord& prim, const Box& box) {
                     return primitiveBounds(program, prim, box);
                   });
}

}  // namespace blobvk::cpu
