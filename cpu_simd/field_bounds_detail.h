// Internal to cpu_simd/field_bounds.cpp and block_bounds.cpp: the box and interval arithmetic
// both bound computations share, and the one run of a Program's code over a box. Not installed
// API; see field_bounds.h for the guarantees.
#pragma once

#include "blobvk/blobtree/pow_field.h"
#include "blobvk/blobtree/triangle_closest.h"
#include "blobvk/cpu_simd/field_bounds.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <vector>

namespace blobvk::cpu::bounds_detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

using Box = BoundsBox;

// Float evaluation of coordinates differs from exact by a few ulps of the largest magnitude
// involved; pad by more than that.
inline Box pad(Box b) {
  if (!b.finite()) return Box::everything();
  for (int a = 0; a < 3; ++a) {
    const double m = std::max({std::abs(b.lo[a]), std::abs(b.hi[a]), 1.0}) * 1e-5;
    b.lo[a] -= m, b.hi[a] += m;
  }
  return b;
}

inline Box transform(const layout::MatrixRecord& m, const Box& b) {
  if (!b.finite()) return Box::everything();
  const layout::vec4 rows[3] = {m.r0, m.r1, m.r2};
  Box out{glm::dvec3(kInf), glm::dvec3(-kInf)};
  for (int r = 0; r < 3; ++r) {
    // Affine image of a box, row by row: each term's min/max is independent.
    const double w[3] = {rows[r].x, rows[r].y, rows[r].z};
    double lo = rows[r].w, hi = rows[r].w, magnitude = std::abs(double(rows[r].w));
    for (int a = 0; a < 3; ++a) {
      const double u = w[a] * b.lo[a], v = w[a] * b.hi[a];
      lo += std::min(u, v), hi += std::max(u, v);
      magnitude += std::max(std::abs(u), std::abs(v));
    }
    // The reference's float sum of products errs by a few ulps of its largest terms, which
    // can exceed a margin relative to the (cancelled) result.
    const double rounding = 1e-6 * magnitude;
    out.lo[r] = lo - rounding, out.hi[r] = hi + rounding;
  }
  return pad(out);
}

inline FieldInterval mul(FieldInterval a, FieldInterval b) {
  const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
  FieldInterval r{*std::min_element(p, p + 4), *std::max_element(p, p + 4)};
  if (std::isnan(r.lo) || std::isnan(r.hi)) r = {-kInf, kInf};
  return r;
}

inline FieldInterval mul(FieldInterval a, double k) { return mul(a, FieldInterval{k, k}); }

// Squared distance between two boxes (0 when they overlap).
inline double boxDistance2(const Box& a, const glm::dvec3& lo, const glm::dvec3& hi) {
  double d2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double gap = std::max({lo[i] - a.hi[i], a.lo[i] - hi[i], 0.0});
    d2 += gap * gap;
  }
  return d2;
}

inline glm::dvec3 xyz(const layout::vec4& v) { return {v.x, v.y, v.z}; }

// Box of the skeleton in the unit frame; the field is a decreasing function of the squared
// distance to the skeleton, so the distance between boxes bounds it from above.
inline void skeletonBox(const layout::PrimitiveRecord& prim, glm::dvec3& lo, glm::dvec3& hi) {
  const glm::dvec3 c = xyz(prim.p0), n = xyz(prim.p1);
  const glm::dvec3 inPlane = glm::dvec3(std::sqrt(std::max(0.0, 1.0 - n.x * n.x)),
                                        std::sqrt(std::max(0.0, 1.0 - n.y * n.y)),
                                        std::sqrt(std::max(0.0, 1.0 - n.z * n.z)));
  switch (prim.meta.x) {
    case layout::PRIM_LINE:
      lo = glm::min(c, c + n), hi = glm::max(c, c + n);
      break;
    case layout::PRIM_CYLINDER: {
      const glm::dvec3 top = c + n * double(prim.p2.y);
      const glm::dvec3 ext = inPlane * double(prim.p2.x);
      lo = glm::min(c, top) - ext, hi = glm::max(c, top) + ext;
      break;
    }
    case layout::PRIM_DISC:
    case layout::PRIM_RING: {
      const glm::dvec3 ext = inPlane * std::abs(double(prim.p2.x));
      lo = c - ext, hi = c + ext;
      break;
    }
    case layout::PRIM_CUBE:
      lo = c - glm::abs(n), hi = c + glm::abs(n);
      break;
    case layout::PRIM_TRIANGLE: {
      const glm::dvec3 q = xyz(prim.p2);
      lo = glm::min(glm::min(c, n), q), hi = glm::max(glm::max(c, n), q);
      break;
    }
    default:  // point, quadric
      lo = hi = c;
      break;
  }
  // Unit-normal rounding and float distance arithmetic: a small absolute pad in the unit frame.
  lo -= glm::dvec3(1e-4), hi += glm::dvec3(1e-4);
}

// Distance in the unit frame from p to the primitive's skeleton (a point, segment, solid
// cylinder, filled disc, circle, box or triangle), in double: the exact function the reference's
// float formulas round. Every one is a Euclidean distance to a set, hence 1-Lipschitz.
inline double skeletonDistance(const layout::PrimitiveRecord& prim, const glm::dvec3& p) {
  const glm::dvec3 c = xyz(prim.p0), n = xyz(prim.p1);
  const glm::dvec3 d = p - c;
  switch (prim.meta.x) {
    case layout::PRIM_LINE: {
      const double len2 = glm::dot(n, n);
      const double t = len2 > 0.0 ? std::clamp(glm::dot(d, n) / len2, 0.0, 1.0) : 0.0;
      return glm::length(d - n * t);
    }
    case layout::PRIM_CYLINDER: {
      const double y = glm::dot(d, n);
      const double x = std::max(std::sqrt(std::max(glm::dot(d, d) - y * y, 0.0)) - double(prim.p2.x), 0.0);
      const double h = std::max({-y, y - double(prim.p2.y), 0.0});
      return std::sqrt(x * x + h * h);
    }
    case layout::PRIM_DISC:
    case layout::PRIM_RING: {
      const double y = glm::dot(d, n);
      double radial = std::sqrt(std::max(glm::dot(d, d) - y * y, 0.0)) - double(prim.p2.x);
      if (prim.meta.x == layout::PRIM_DISC) radial = std::max(radial, 0.0);
      return std::sqrt(radial * radial + y * y);
    }
    case layout::PRIM_CUBE:
      return glm::length(glm::max(glm::abs(d) - n, glm::dvec3(0.0)));
    case layout::PRIM_TRIANGLE:
      return glm::length(p - blobtree::detail::triangleClosest<double>(p, c, n, xyz(prim.p2)));
    default:  // point, quadric
      return glm::length(d);
  }
}

// Bounds of one primitive's field over a box of its point register (field_bounds.cpp).
FieldInterval primitiveBounds(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                              const Box& world);

// Conservative box of the warp's image of `b` (field_bounds.cpp; infinite for bends).
Box warpBox(const blobtree::Program& program, const layout::WarpRecord& warp, Box b);

// The code run once over a box: `primitive(pc, record, pointBox)` bounds one primitive.
template <typename PrimitiveBound>
FieldInterval runBounds(const blobtree::Program& program, const Box& box,
                        PrimitiveBound&& primitive) {
  std::array<FieldInterval, layout::MAX_FIELD_REGISTERS> reg{};
  std::array<Box, layout::MAX_POINT_REGISTERS> pts{};
  pts[0] = box;
  struct Pending {
    std::uint32_t target, dst;
  };
  std::vector<Pending> pending;  // partial skips: the register also takes 0 where the box ends
  const std::size_t n = program.code.size();
  std::size_t pc = 0;
  for (;;) {
    while (!pending.empty() && pending.back().target <= pc) {
      FieldInterval& r = reg[pending.back().dst];
      r.lo = std::min(r.lo, 0.0), r.hi = std::max(r.hi, 0.0);
      pending.pop_back();
    }
    if (pc >= n) break;
    const layout::uvec4 in = program.code[pc].code;
    const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
    FieldInterval& d = reg[dst];
    switch (op) {
      case layout::OP_PRIM:
        d = primitive(pc, program.primitives[in.y], pts[in.z]);
        break;
      case layout::OP_ADD:
        d = {d.lo + reg[in.y].lo, d.hi + reg[in.y].hi};
        break;
      case layout::OP_MAX:
        d = {std::max(d.lo, reg[in.y].lo), std::max(d.hi, reg[in.y].hi)};
        break;
      case layout::OP_MIN:
        d = {std::min(d.lo, reg[in.y].lo), std::min(d.hi, reg[in.y].hi)};
        break;
      case layout::OP_DIFF:
        d = {std::min(d.lo, 1.0 - reg[in.y].hi), std::min(d.hi, 1.0 - reg[in.y].lo)};
        break;
      case layout::OP_SDIFF:
        d = mul(d, FieldInterval{1.0 - reg[in.y].hi, 1.0 - reg[in.y].lo});
        break;
      case layout::OP_ONE_MINUS:
        d = {1.0 - d.hi, 1.0 - d.lo};
        break;
      case layout::OP_MUL:
        d = mul(d, reg[in.y]);
        break;
      case layout::OP_POW: {
        const double e = std::bit_cast<float>(in.w);
        if (e > 0.0) {
          blobtree::powFieldBounds(d.lo, d.hi, e);
        } else {
          d = {0.0, kInf};
        }
        break;
      }
      case layout::OP_WARP:
        pts[dst] = warpBox(program, program.warps[in.y], pts[in.z]);
        break;
      case layout::OP_SKIP: {
        const layout::BoxRecord& s = program.boxes[in.y];
        const Box& q = pts[in.z];
        const bool disjoint = q.hi.x < s.lo.x || q.hi.y < s.lo.y || q.hi.z < s.lo.z ||
                              q.lo.x > s.hi.x || q.lo.y > s.hi.y || q.lo.z > s.hi.z;
        if (disjoint) {
          d = {0.0, 0.0};
          pc = in.w;
          continue;
        }
        const bool inside = q.lo.x >= s.lo.x && q.lo.y >= s.lo.y && q.lo.z >= s.lo.z &&
                            q.hi.x <= s.hi.x && q.hi.y <= s.hi.y && q.hi.z <= s.hi.z;
        if (!inside) pending.push_back({in.w, dst});
        break;
      }
      default:
        break;
    }
    ++pc;
  }
  // Float rounding of sums and products: widen by a relative margin.
  FieldInterval r = n ? reg[0] : FieldInterval{};
  const double m = 1e-4 * std::max({1.0, std::abs(r.lo), std::abs(r.hi)});
  return {r.lo - m, r.hi + m};
}

}  // namespace blobvk::cpu::bounds_detail
