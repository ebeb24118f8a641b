// See field_bounds.h. Boxes are tracked in double and padded by a relative margin wherever a
// float computation of the reference could land outside the exact-arithmetic value.
#include "blobvk/cpu_simd/field_bounds.h"

#include "blobvk/cpu_simd/field_bounds_detail.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

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

namespace {
// The (u, v) box of the points of the rectangle [u0, u1] x [v0, v1] turned by every angle in
// [t0, t1] (either order), r being the distance of its farthest corner from the origin: the
// intersection of three boxes that each hold them all. The disc of radius r. The rectangle turned
// by the middle angle (its corners' box), grown by r times half the span (a chord is shorter than
// its arc): tight where the span is short beside the rectangle's own angles. Where the rectangle
// leaves out the origin and the angles (the rectangle's own, plus the turn) span less than a
// whole turn, the box of that annular sector (its four end points and the directions of the
// axes it reaches at radius r): tight where the turn is long. The angles keep a margin for the
// reference's float angle and sin/cos, the boxes kTrigPositionMargin r for a device's sin and
// cos; the caller pads the result for the rotation's float rounding.
//
// Vulkan allows sin and cos an absolute error of 2^-11 within [-pi, pi], which moves a turned
// point by up to 2 * 2^-11 r (under 1e-3 r) from the exact one: with that margin the bound holds
// for any conformant device's twist there, and for llvmpipe's at any angle (its sin and cos
// reduce the angle first, and err by about 1e-7: tests/vk/test_row_culling.cpp), so that its
// row culling and host classification run on twisted and bent programs (ColumnSides::
// boundsHoldOnIeeeDevices). It costs the CPU's bound a thousandth of the radius.
constexpr double kTrigPositionMargin = 1e-3;
struct TurnedBox {
  double lo[2], hi[2];
};
TurnedBox turnedRectangle(double u0, double u1, double v0, double v1, double t0, double t1) {
  const double r = std::sqrt(std::max(u0 * u0, u1 * u1) + std::max(v0 * v0, v1 * v1));
  const double m = kTrigPositionMargin * r, reach = r + m;
  TurnedBox s{{-reach, -reach}, {reach, reach}};
  if (t0 > t1) std::swap(t0, t1);
  // The reference computes the angle in float (k * p[a]) and its sine and cosine with libm's
  // float functions: a few ulps of the angle, and an absolute slack for sin and cos.
  const double slack = 1e-6 * (std::max(std::abs(t0), std::abs(t1)) + 1.0);
  if (!std::isfinite(t1 - t0) || !std::isfinite(r)) return s;
  auto cut = [&](const double lo[2], const double hi[2], double grow) {
    for (int i = 0; i < 2; ++i) s.lo[i] = std::max(s.lo[i], lo[i] - grow), s.hi[i] = std::min(s.hi[i], hi[i] + grow);
  };
  {  // the rectangle turned by the middle angle
    const double middle = 0.5 * (t0 + t1), c = std::cos(middle), sn = std::sin(middle);
    double lo[2] = {kInf, kInf}, hi[2] = {-kInf, -kInf};
    for (const double cu : {u0, u1})
      for (const double cv : {v0, v1}) {
        const double pu = cu * c - cv * sn, pv = cu * sn + cv * c;
        lo[0] = std::min(lo[0], pu), hi[0] = std::max(hi[0], pu);
        lo[1] = std::min(lo[1], pv), hi[1] = std::max(hi[1], pv);
      }
    cut(lo, hi, r * (0.5 * (t1 - t0) + slack) + m);
  }
  if (u0 <= 0.0 && u1 >= 0.0 && v0 <= 0.0 && v1 >= 0.0) return s;  // the axis crosses the box
  // The annular sector: the rectangle's nearest distance from the origin, and its corners' angles
  // about the angle of its centre (a rectangle that leaves out the origin spans less than half a
  // turn seen from it).
  const double nu = std::clamp(0.0, u0, u1), nv = std::clamp(0.0, v0, v1);
  const double rmin = std::sqrt(nu * nu + nv * nv);
  const double centre = std::atan2(0.5 * (v0 + v1), 0.5 * (u0 + u1));
  double f0 = std::numbers::pi, f1 = -std::numbers::pi;
  for (const double cu : {u0, u1})
    for (const double cv : {v0, v1}) {
      double f = std::atan2(cv, cu) - centre;
      if (f > std::numbers::pi) f -= 2.0 * std::numbers::pi;
      if (f < -std::numbers::pi) f += 2.0 * std::numbers::pi;
      f0 = std::min(f0, f), f1 = std::max(f1, f);
    }
  const double from = centre + f0 + t0 - slack, to = centre + f1 + t1 + slack;
  if (!(to - from < 2.0 * std::numbers::pi)) return s;
  double lo[2] = {kInf, kInf}, hi[2] = {-kInf, -kInf};
  auto take = [&](double radius, double angle) {
    const double pu = radius * std::cos(angle), pv = radius * std::sin(angle);
    lo[0] = std::min(lo[0], pu), hi[0] = std::max(hi[0], pu);
    lo[1] = std::min(lo[1], pv), hi[1] = std::max(hi[1], pv);
  };
  for (const double radius : {rmin, r}) take(radius, from), take(radius, to);
  // The directions of the axes (multiples of a quarter turn) within the sector's angles.
  const double quarter = 0.5 * std::numbers::pi;
  for (double q = std::ceil(from / quarter) * quarter; q <= to; q += quarter) take(r, q);
  cut(lo, hi, m);
  return s;
}
}  // namespace

Box warpBox(const blobtree::Program& program, const layout::WarpRecord& warp, Box b) {
  if (warp.meta.w != 0u) b = transform(program.matrices[warp.meta.w], b);
  if (!b.finite()) return b;
  const unsigned a = warp.meta.y, c = warp.meta.z;
  const double k = warp.params.x;
  switch (warp.meta.x) {
    case layout::WARP_TWIST: {
      // A rotation about axis a by k * p[a]: the coordinate along a stays, and the box's
      // cross-section turns by the angles k times its extent along a gives.
      const unsigned u = (a + 1u) % 3u, v = (a + 2u) % 3u;
      const TurnedBox t = turnedRectangle(b.lo[u], b.hi[u], b.lo[v], b.hi[v], k * b.lo[a], k * b.hi[a]);
      b.lo[u] = t.lo[0], b.hi[u] = t.hi[0];
      b.lo[v] = t.lo[1], b.hi[v] = t.hi[1];
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
    case layout::WARP_BEND: {
      // The reference maps p to (c0, 1/k) + R(theta) (beyond, p[c] - 1/k): a turn by theta =
      // k (clamp(p[a], lo, hi) - c0) of how far p lies past the bent region along a (`beyond`,
      // 0 within it) and from the arc's centre line towards c. Bounding theta and the rectangle of
      // (beyond, p[c] - 1/k) apart is conservative; the turn's bound is the twist's.
      if (k == 0.0) return pad(b);
      // 1/k as the evaluators compute it, in float: near the centre line a box's turned point
      // lies about |1/k| from it, and the exact 1/k differs by up to 6e-8 of that, more than the
      // padding on axis a. A device may round its own division by 2.5 ulps: 1e-6 |1/k| kept.
      const float invKf = 1.0f / warp.params.x;
      if (!std::isfinite(invKf)) return Box::everything();  // a subnormal rate: the reference gives inf
      const double c0 = warp.params.y, lo = warp.params.z, hi = warp.params.w, invK = invKf;
      const double divisionMargin = 1e-6 * std::abs(invK);
      const double y0 = std::clamp(b.lo[a], lo, hi), y1 = std::clamp(b.hi[a], lo, hi);
      const double u0 = b.lo[a] - y0, u1 = b.hi[a] - y1;  // `beyond` grows with p[a]
      const double v0 = b.lo[c] - invK, v1 = b.hi[c] - invK;
      const TurnedBox t = turnedRectangle(u0, u1, v0, v1, k * (y0 - c0), k * (y1 - c0));
      b.lo[a] = t.lo[0] + c0 - divisionMargin, b.hi[a] = t.hi[0] + c0 + divisionMargin;
      b.lo[c] = t.lo[1] + invK - divisionMargin, b.hi[c] = t.hi[1] + invK + divisionMargin;
      return pad(b);
    }
    default:  // unknown: the reference leaves the point as it is
      return pad(b);
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
