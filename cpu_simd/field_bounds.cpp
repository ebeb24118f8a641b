// See field_bounds.h. Boxes are tracked in double and padded by a relative margin wherever a
// float computation of the reference could land outside the exact-arithmetic value.
#include "blobvk/cpu_simd/field_bounds.h"

#include "blobvk/blobtree/triangle_closest.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <vector>

namespace blobvk::cpu {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using Box = BoundsBox;

// Float evaluation of coordinates differs from exact by a few ulps of the largest magnitude
// involved; pad by more than that.
Box pad(Box b) {
  if (!b.finite()) return Box::everything();
  for (int a = 0; a < 3; ++a) {
    const double m = std::max({std::abs(b.lo[a]), std::abs(b.hi[a]), 1.0}) * 1e-5;
    b.lo[a] -= m, b.hi[a] += m;
  }
  return b;
}

Box transform(const layout::MatrixRecord& m, const Box& b) {
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

FieldInterval mul(FieldInterval a, FieldInterval b) {
  const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
  FieldInterval r{*std::min_element(p, p + 4), *std::max_element(p, p + 4)};
  if (std::isnan(r.lo) || std::isnan(r.hi)) r = {-kInf, kInf};
  return r;
}

FieldInterval mul(FieldInterval a, double k) { return mul(a, FieldInterval{k, k}); }

// Squared distance between two boxes (0 when they overlap).
double boxDistance2(const Box& a, const glm::dvec3& lo, const glm::dvec3& hi) {
  double d2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double gap = std::max({lo[i] - a.hi[i], a.lo[i] - hi[i], 0.0});
    d2 += gap * gap;
  }
  return d2;
}

glm::dvec3 xyz(const layout::vec4& v) { return {v.x, v.y, v.z}; }

// Box of the skeleton in the unit frame; the field is a decreasing function of the squared
// distance to the skeleton, so the distance between boxes bounds it from above.
void skeletonBox(const layout::PrimitiveRecord& prim, glm::dvec3& lo, glm::dvec3& hi) {
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
double skeletonDistance(const layout::PrimitiveRecord& prim, const glm::dvec3& p) {
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

}  // namespace

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

namespace {

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
          d = {std::pow(std::max(d.lo, 0.0), e), std::pow(std::max(d.hi, 0.0), e)};
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

}  // namespace

FieldInterval fieldBounds(const blobtree::Program& program, const glm::dvec3& lo,
                          const glm::dvec3& hi) {
  return runBounds(program, pad(Box{lo, hi}),
                   [&](std::size_t, const layout::PrimitiveRecord& prim, const Box& box) {
                     return primitiveBounds(program, prim, box);
                   });
}

void BlockBounds::reset(const blobtree::Program& program, const glm::dvec3& regionLo,
                        const glm::dvec3& regionHi) {
  program_ = &program;
  regionLo_ = regionLo, regionHi_ = regionHi;
  regionMax_ = std::max({std::abs(regionLo.x), std::abs(regionLo.y), std::abs(regionLo.z),
                         std::abs(regionHi.x), std::abs(regionHi.y), std::abs(regionHi.z)});
  general_ = false;
  skips_ = false;
  for (const layout::Instruction& in : program.code) {
    if ((in.code.x & 0xffu) == layout::OP_WARP) general_ = true;
    if ((in.code.x & 0xffu) == layout::OP_SKIP) skips_ = true;
  }
  registers_ = 1;
  for (const layout::Instruction& in : program.code)
    registers_ = std::max(registers_, std::size_t(in.code.x >> 8) + 1);
  // Indexed by instruction (pruned tapes are short; their primitive tables are not).
  prims_.resize(program.code.size());
  for (std::size_t pc = 0; pc < program.code.size(); ++pc) {
    const layout::uvec4 in = program.code[pc].code;
    if ((in.x & 0xffu) != layout::OP_PRIM) continue;
    const layout::PrimitiveRecord& prim = program.primitives[in.y];
    Prim& q = prims_[pc];
    skeletonBox(prim, q.skeletonLo, q.skeletonHi);
    q.matrix = prim.meta.y != 0u;
    q.offsetMax = 0.0, q.rowAbsMax = 1.0;
    // The identity for the batched pass (1 * x + 0 * y + 0 * z + 0 is x exactly).
    q.rows[0] = glm::dvec3(1, 0, 0), q.rows[1] = glm::dvec3(0, 1, 0), q.rows[2] = glm::dvec3(0, 0, 1);
    q.offset = glm::dvec3(0.0);
    if (q.matrix) {
      const layout::MatrixRecord& m = program.matrices[prim.meta.y];
      q.rows[0] = xyz(m.r0), q.rows[1] = xyz(m.r1), q.rows[2] = xyz(m.r2);
      q.offset = glm::dvec3(m.r0.w, m.r1.w, m.r2.w);
      q.offsetMax = std::max({std::abs(q.offset.x), std::abs(q.offset.y), std::abs(q.offset.z)});
      q.rowAbsMax = 0.0;
      for (const glm::dvec3& r : q.rows)
        q.rowAbsMax = std::max(q.rowAbsMax, std::abs(r.x) + std::abs(r.y) + std::abs(r.z));
    }
  }
  halfExtent_ = glm::dvec3(-1.0);  // no size cached yet
}

void BlockBounds::cacheSize(const glm::dvec3& e) {
  halfExtent_ = e;
  const double eMax = std::max({e.x, e.y, e.z});
  for (std::size_t pc = 0; pc < prims_.size(); ++pc) {
    Prim& q = prims_[pc];
    if ((program_->code[pc].code.x & 0xffu) != layout::OP_PRIM) continue;
    double radius = glm::length(e);
    glm::dvec3 localHalf = e;
    if (q.matrix) {
      // The image of the box is a parallelepiped centred on the image of the centre; its
      // farthest points are corners, and opposite corners are equally far: four sign patterns.
      radius = 0.0;
      for (const glm::dvec3 sgn : {glm::dvec3(1, 1, 1), glm::dvec3(1, 1, -1), glm::dvec3(1, -1, 1),
                                   glm::dvec3(1, -1, -1)}) {
        const glm::dvec3 v = sgn * e;
        radius = std::max(radius, glm::length(glm::dvec3(glm::dot(q.rows[0], v), glm::dot(q.rows[1], v),
                                                         glm::dot(q.rows[2], v))));
      }
      for (int r = 0; r < 3; ++r) localHalf[r] = glm::dot(glm::abs(q.rows[r]), e);
    }
    // More than the reference's float rounding of the transform (transform() and pad()'s
    // margins, for coordinates of the region's magnitude) and of the distance arithmetic in
    // the unit frame (skeletonBox's 1e-4).
    const double world = regionMax_ + eMax;
    const double local = q.offsetMax + q.rowAbsMax * world;
    const double slack = 2e-5 * (1.0 + q.offsetMax + q.rowAbsMax * world + local + radius) +
                         1e-5 * q.rowAbsMax * std::max(1.0, world) + 1e-4;
    q.reach = radius + slack;
    q.localHalf = localHalf + glm::dvec3(slack);
  }
}

FieldInterval BlockBounds::operator()(const glm::dvec3& lo, const glm::dvec3& hi) {
  const blobtree::Program& program = *program_;
  const Box raw{lo, hi};
  const bool inRegion = glm::all(glm::greaterThanEqual(glm::min(lo, hi), regionLo_)) &&
                        glm::all(glm::lessThanEqual(glm::max(lo, hi), regionHi_));
  if (general_ || !inRegion || !raw.finite()) return fieldBounds(program, lo, hi);
  // The box itself only meets skip instructions (primitives use the ball below).
  const Box box = skips_ ? pad(raw) : raw;
  // Centre and half extent of the unpadded box (the padding is in the slack). Boxes of one
  // grid block size differ in their last bits: a cached size at most 0.1% larger serves.
  const glm::dvec3 c = (lo + hi) * 0.5, e = glm::abs(hi - lo) * 0.5;
  if (glm::any(glm::greaterThan(e, halfExtent_)) || glm::any(glm::lessThan(e * 1.001, halfExtent_)))
    cacheSize(e * (1.0 + 1e-4));
  return runBounds(program, box, [&](std::size_t pc, const layout::PrimitiveRecord& prim, const Box&) -> FieldInterval {
    if (prim.meta.x > layout::PRIM_QUADRIC) return {0.0, 0.0};
    const Prim& q = prims_[pc];
    glm::dvec3 centre = c;
    if (q.matrix)
      centre = glm::dvec3(glm::dot(q.rows[0], c), glm::dot(q.rows[1], c), glm::dot(q.rows[2], c)) + q.offset;
    const double distance = skeletonDistance(prim, centre);
    const double near = std::max(distance - q.reach, 0.0), far = distance + q.reach;
    double ddMin = near * near;
    if (ddMin >= 1.0) return {0.0, 0.0};
    ddMin = std::max(ddMin, boxDistance2(Box{centre - q.localHalf, centre + q.localHalf}, q.skeletonLo,
                                         q.skeletonHi));
    if (ddMin >= 1.0) return {0.0, 0.0};
    const double tHi = 1.0 - ddMin, tLo = std::max(1.0 - far * far, 0.0);
    if (prim.meta.x == layout::PRIM_QUADRIC) {
      const double scale = double(prim.p0.w);
      const double u = scale * tLo * tLo, v = scale * tHi * tHi;
      return {std::min(u, v), std::max(u, v)};
    }
    return {tLo * tLo * tLo, tHi * tHi * tHi};
  });
}


namespace {

// One primitive's interval over a batch of boxes of one size (centres c*, the cached size in
// `q`), the scalar operator()'s arithmetic per box in loops the compiler vectorises.
template <std::uint32_t Type, typename Prim>
void primitiveBatch(const layout::PrimitiveRecord& prim, const Prim& q, std::size_t n, const double* cx,
                    const double* cy, const double* cz, double* lo, double* hi) {
  const glm::dvec3 c0 = xyz(prim.p0), n1 = xyz(prim.p1), p2 = xyz(prim.p2);
  const double len2 = glm::dot(n1, n1), invLen2 = len2 > 0.0 ? 1.0 / len2 : 0.0;
  const double scale = Type == layout::PRIM_QUADRIC ? double(prim.p0.w) : 1.0;
  const glm::dvec3 r0 = q.rows[0], r1 = q.rows[1], r2 = q.rows[2], o = q.offset;
  const glm::dvec3 sLo = q.skeletonLo, sHi = q.skeletonHi, half = q.localHalf;
  const double reach = q.reach;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = cx[i], y = cy[i], z = cz[i];
    const double lx = r0.x * x + r0.y * y + r0.z * z + o.x;
    const double ly = r1.x * x + r1.y * y + r1.z * z + o.y;
    const double lz = r2.x * x + r2.y * y + r2.z * z + o.z;
    const double dx = lx - c0.x, dy = ly - c0.y, dz = lz - c0.z;
    double dist;
    if constexpr (Type == layout::PRIM_LINE) {
      const double t = std::clamp((dx * n1.x + dy * n1.y + dz * n1.z) * invLen2, 0.0, 1.0);
      const double ex = dx - n1.x * t, ey = dy - n1.y * t, ez = dz - n1.z * t;
      dist = std::sqrt(ex * ex + ey * ey + ez * ez);
    } else if constexpr (Type == layout::PRIM_CYLINDER || Type == layout::PRIM_DISC ||
                         Type == layout::PRIM_RING) {
      const double a = dx * n1.x + dy * n1.y + dz * n1.z;
      const double r = std::sqrt(std::max(dx * dx + dy * dy + dz * dz - a * a, 0.0));
      if constexpr (Type == layout::PRIM_CYLINDER) {
        const double u = std::max(r - p2.x, 0.0);
        const double h = std::max(std::max(-a, a - p2.y), 0.0);
        dist = std::sqrt(u * u + h * h);
      } else {
        const double radial = Type == layout::PRIM_DISC ? std::max(r - p2.x, 0.0) : r - p2.x;
        dist = std::sqrt(radial * radial + a * a);
      }
    } else if constexpr (Type == layout::PRIM_CUBE) {
      const double ex = std::max(std::abs(dx) - n1.x, 0.0), ey = std::max(std::abs(dy) - n1.y, 0.0),
                   ez = std::max(std::abs(dz) - n1.z, 0.0);
      dist = std::sqrt(ex * ex + ey * ey + ez * ez);
    } else {  // point, quadric
      dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    }
    const double near = std::max(dist - reach, 0.0), far = dist + reach;
    const double gx = std::max(std::max(sLo.x - (lx + half.x), (lx - half.x) - sHi.x), 0.0);
    const double gy = std::max(std::max(sLo.y - (ly + half.y), (ly - half.y) - sHi.y), 0.0);
    const double gz = std::max(std::max(sLo.z - (lz + half.z), (lz - half.z) - sHi.z), 0.0);
    const double ddMin = std::max(near * near, gx * gx + gy * gy + gz * gz);
    const double tHi = std::max(1.0 - ddMin, 0.0), tLo = std::max(1.0 - far * far, 0.0);
    if constexpr (Type == layout::PRIM_QUADRIC) {
      const double u = scale * tLo * tLo, v = scale * tHi * tHi;
      lo[i] = std::min(u, v), hi[i] = std::max(u, v);
    } else {
      lo[i] = tLo * tLo * tLo, hi[i] = tHi * tHi * tHi;
    }
  }
}

}  // namespace

void BlockBounds::operator()(std::size_t n, const double* cx, const double* cy, const double* cz,
                             const glm::dvec3& halfExtent, double* outLo, double* outHi) {
  const blobtree::Program& program = *program_;
  if (general_) {  // warps: per box, through the scalar path
    for (std::size_t i = 0; i < n; ++i) {
      const glm::dvec3 c(cx[i], cy[i], cz[i]);
      const FieldInterval f = (*this)(c - halfExtent, c + halfExtent);
      outLo[i] = f.lo, outHi[i] = f.hi;
    }
    return;
  }
  if (glm::any(glm::greaterThan(halfExtent, halfExtent_)) ||
      glm::any(glm::lessThan(halfExtent * 1.001, halfExtent_)))
    cacheSize(halfExtent * (1.0 + 1e-4));
  regLo_.resize(registers_ * n), regHi_.resize(registers_ * n);
  std::fill(regLo_.begin(), regLo_.end(), 0.0);
  std::fill(regHi_.begin(), regHi_.end(), 0.0);
  // Skips: boxes differ in whether they meet the skip's box, so the subtree runs for all of
  // them (a valid run for every box: the code is correct whether or not it jumps) and at the
  // skip's target its register becomes 0 for the boxes that miss the skip's box (the jump's
  // value) or takes 0 into its interval for the boxes that straddle it (as fieldBounds does).
  struct Pending {
    std::uint32_t target, dst;
    std::size_t modes;  // offset into skipModes_: per box 0 inside, 1 straddling, 2 disjoint
  };
  std::vector<Pending> pending;
  skipModes_.clear();
  for (std::size_t pc = 0;; ++pc) {
    while (!pending.empty() && pending.back().target <= pc) {
      const Pending p = pending.back();
      pending.pop_back();
      double* dl = regLo_.data() + std::size_t(p.dst) * n;
      double* dh = regHi_.data() + std::size_t(p.dst) * n;
      const std::uint8_t* mode = skipModes_.data() + p.modes;
      for (std::size_t i = 0; i < n; ++i) {
        if (mode[i] == 2) dl[i] = dh[i] = 0.0;
        if (mode[i] == 1) dl[i] = std::min(dl[i], 0.0), dh[i] = std::max(dh[i], 0.0);
      }
      skipModes_.resize(p.modes);
    }
    if (pc >= program.code.size()) break;
    const layout::uvec4 in = program.code[pc].code;
    const std::uint32_t op = in.x & 0xffu;
    if (op == layout::OP_SKIP) {
      const layout::BoxRecord& sb = program.boxes[in.y];
      const std::size_t at = skipModes_.size();
      skipModes_.resize(at + n);
      for (std::size_t i = 0; i < n; ++i) {
        // pad()'s margin, inline: 1e-5 of the largest coordinate magnitude (at least 1).
        const glm::dvec3 c(cx[i], cy[i], cz[i]);
        const glm::dvec3 grow = (halfExtent + 1e-5 * glm::max(glm::abs(c) + halfExtent, glm::dvec3(1.0)));
        const Box q{c - grow, c + grow};
        const bool disjoint = q.hi.x < sb.lo.x || q.hi.y < sb.lo.y || q.hi.z < sb.lo.z ||
                              q.lo.x > sb.hi.x || q.lo.y > sb.hi.y || q.lo.z > sb.hi.z;
        const bool inside = q.lo.x >= sb.lo.x && q.lo.y >= sb.lo.y && q.lo.z >= sb.lo.z &&
                            q.hi.x <= sb.hi.x && q.hi.y <= sb.hi.y && q.hi.z <= sb.hi.z;
        skipModes_[at + i] = disjoint ? 2 : inside ? 0 : 1;
      }
      pending.push_back({in.w, in.x >> 8, at});
      continue;
    }
    double* __restrict dl = regLo_.data() + std::size_t(in.x >> 8) * n;
    double* __restrict dh = regHi_.data() + std::size_t(in.x >> 8) * n;
    const double* sl = regLo_.data() + std::size_t(in.y) * n;
    const double* sh = regHi_.data() + std::size_t(in.y) * n;
    switch (op) {
      case layout::OP_PRIM: {
        const layout::PrimitiveRecord& prim = program.primitives[in.y];
        const Prim& q = prims_[pc];
        switch (prim.meta.x) {
          case layout::PRIM_POINT: primitiveBatch<layout::PRIM_POINT>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_LINE: primitiveBatch<layout::PRIM_LINE>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_CYLINDER: primitiveBatch<layout::PRIM_CYLINDER>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_DISC: primitiveBatch<layout::PRIM_DISC>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_RING: primitiveBatch<layout::PRIM_RING>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_CUBE: primitiveBatch<layout::PRIM_CUBE>(prim, q, n, cx, cy, cz, dl, dh); break;
          case layout::PRIM_QUADRIC: primitiveBatch<layout::PRIM_QUADRIC>(prim, q, n, cx, cy, cz, dl, dh); break;
          default: {
            // Triangles (and unknown types) per box through the scalar primitive bound.
            for (std::size_t i = 0; i < n; ++i) {
              const glm::dvec3 c(cx[i], cy[i], cz[i]);
              const FieldInterval f = primitiveBounds(program, prim, pad(Box{c - halfExtent, c + halfExtent}));
              dl[i] = f.lo, dh[i] = f.hi;
            }
            break;
          }
        }
        break;
      }
      case layout::OP_ADD:
        for (std::size_t i = 0; i < n; ++i) dl[i] += sl[i], dh[i] += sh[i];
        break;
      case layout::OP_MAX:
        for (std::size_t i = 0; i < n; ++i) dl[i] = std::max(dl[i], sl[i]), dh[i] = std::max(dh[i], sh[i]);
        break;
      case layout::OP_MIN:
        for (std::size_t i = 0; i < n; ++i) dl[i] = std::min(dl[i], sl[i]), dh[i] = std::min(dh[i], sh[i]);
        break;
      case layout::OP_DIFF:
        for (std::size_t i = 0; i < n; ++i) {
          const double l = std::min(dl[i], 1.0 - sh[i]), h = std::min(dh[i], 1.0 - sl[i]);
          dl[i] = l, dh[i] = h;
        }
        break;
      case layout::OP_ONE_MINUS:
        for (std::size_t i = 0; i < n; ++i) {
          const double l = 1.0 - dh[i], h = 1.0 - dl[i];
          dl[i] = l, dh[i] = h;
        }
        break;
      case layout::OP_SDIFF:
      case layout::OP_MUL:
      case layout::OP_POW:
        // Rare in pruned tapes: the scalar interval arithmetic, box by box.
        for (std::size_t i = 0; i < n; ++i) {
          FieldInterval d{dl[i], dh[i]};
          if (op == layout::OP_SDIFF) {
            d = mul(d, FieldInterval{1.0 - sh[i], 1.0 - sl[i]});
          } else if (op == layout::OP_MUL) {
            d = mul(d, FieldInterval{sl[i], sh[i]});
          } else {
            const double e = std::bit_cast<float>(in.w);
            d = e > 0.0 ? FieldInterval{std::pow(std::max(d.lo, 0.0), e), std::pow(std::max(d.hi, 0.0), e)}
                        : FieldInterval{0.0, kInf};
          }
          dl[i] = d.lo, dh[i] = d.hi;
        }
        break;
      default:
        break;
    }
  }
  // Float rounding of sums and products: widen by a relative margin (as fieldBounds).
  for (std::size_t i = 0; i < n; ++i) {
    const double l = program.code.empty() ? 0.0 : regLo_[i], h = program.code.empty() ? 0.0 : regHi_[i];
    const double m = 1e-4 * std::max({1.0, std::abs(l), std::abs(h)});
    outLo[i] = l - m, outHi[i] = h + m;
  }
}

}  // namespace blobvk::cpu
