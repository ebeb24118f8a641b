// See block_bounds.h: fieldBounds's arithmetic for many boxes of one size, with the per-size
// parts cached and the boxes of a batch bounded one instruction at a time.
#include "blobvk/cpu_simd/block_bounds.h"

#include "blobvk/cpu_simd/field_bounds_detail.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>

namespace blobvk::cpu {

using namespace bounds_detail;

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
// Always inlined: it is compiled into each clone of the batch (below), AVX2 included.
template <std::uint32_t Type, typename Prim>
[[gnu::always_inline]] inline void primitiveBatch(const layout::PrimitiveRecord& prim, const Prim& q, std::size_t n, const double* cx,
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

// The batch's loops over boxes vectorise 4 doubles wide with AVX2 against 2 with the baseline's
// SSE2: cloned (function multi-versioning), the loader picks the AVX2 clone where the CPU has it.
// No FMA in the clone, so both compute the same bounds.
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
__attribute__((target_clones("avx2", "default")))
#endif
#endif
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
            if (e > 0.0) {
              blobtree::powFieldBounds(d.lo, d.hi, e);
            } else {
              d = FieldInterval{0.0, kInf};
            }
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
