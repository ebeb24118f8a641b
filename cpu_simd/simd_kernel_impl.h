// Internal: the evaluator written once over a lane type V (see simd_avx2.cpp, simd_avx512.cpp,
// which define V with intrinsics and include this file). Every formula mirrors
// blobtree/evaluate.cpp operation for operation and in the same order, so each lane computes the
// bits the scalar reference computes. Only ISA-specific files include this header.
//
// V must provide: V::W, V(float) broadcast, V::load/store, + - * /, vmax/vmin with std::max/min
// semantics, vsqrt, vabs, comparisons returning V::Mask, select(mask, a, b), any/all, mask & | ~.
#pragma once

#include "blobtree/program.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace blobvk::cpu::detail {

template <class V>
struct Vec3V {
  V x, y, z;
};

template <class V>
inline V dot3(const V& ax, const V& ay, const V& az, const V& bx, const V& by, const V& bz) {
  return ax * bx + ay * by + az * bz;  // (x + y) + z, as glm::dot
}

template <class V>
inline Vec3V<V> toLocal(const layout::MatrixRecord& m, const Vec3V<V>& p) {
  return {V(m.r0.x) * p.x + V(m.r0.y) * p.y + V(m.r0.z) * p.z + V(m.r0.w),
          V(m.r1.x) * p.x + V(m.r1.y) * p.y + V(m.r1.z) * p.z + V(m.r1.w),
          V(m.r2.x) * p.x + V(m.r2.y) * p.y + V(m.r2.z) * p.z + V(m.r2.w)};
}

template <class V>
inline V wyvillV(const V& dd) {
  const V t = V(1.0f) - dd;
  return select(dd < V(1.0f), t * t * t, V(0.0f));
}

template <class V>
V triangleDd(const Vec3V<V>& p, const layout::PrimitiveRecord& prim) {
  using M = typename V::Mask;
  const V zero(0.0f);
  const V ax(prim.p0.x), ay(prim.p0.y), az(prim.p0.z);
  const V bx(prim.p1.x), by(prim.p1.y), bz(prim.p1.z);
  const V cx(prim.p2.x), cy(prim.p2.y), cz(prim.p2.z);
  const V abx = bx - ax, aby = by - ay, abz = bz - az;
  const V acx = cx - ax, acy = cy - ay, acz = cz - az;
  const V apx = p.x - ax, apy = p.y - ay, apz = p.z - az;
  const V d1 = dot3(abx, aby, abz, apx, apy, apz), d2 = dot3(acx, acy, acz, apx, apy, apz);
  const V bpx = p.x - bx, bpy = p.y - by, bpz = p.z - bz;
  const V d3 = dot3(abx, aby, abz, bpx, bpy, bpz), d4 = dot3(acx, acy, acz, bpx, bpy, bpz);
  const V cpx = p.x - cx, cpy = p.y - cy, cpz = p.z - cz;
  const V d5 = dot3(abx, aby, abz, cpx, cpy, cpz), d6 = dot3(acx, acy, acz, cpx, cpy, cpz);
  const V vc = d1 * d4 - d3 * d2;
  const V vb = d5 * d2 - d1 * d6;
  const V va = d3 * d6 - d5 * d4;
  // Interior (the last branch of the reference), then each earlier branch overrides in reverse
  // priority so the first true condition wins, as in the if-chain.
  const V sum = va + vb + vc;
  const V denom = select(sum != zero, V(1.0f) / sum, zero);
  const V s = vb * denom, t = vc * denom;
  V qx = ax + abx * s + acx * t, qy = ay + aby * s + acy * t, qz = az + abz * s + acz * t;
  const V d43 = d4 - d3, d56 = d5 - d6;
  const M inBC = (va <= zero) & (d43 >= zero) & (d56 >= zero);
  {
    const V u = d43 / (d43 + d56);
    qx = select(inBC, bx + (cx - bx) * u, qx);
    qy = select(inBC, by + (cy - by) * u, qy);
    qz = select(inBC, bz + (cz - bz) * u, qz);
  }
  const M inAC = (vb <= zero) & (d2 >= zero) & (d6 <= zero);
  {
    const V u = d2 / (d2 - d6);
    qx = select(inAC, ax + acx * u, qx);
    qy = select(inAC, ay + acy * u, qy);
    qz = select(inAC, az + acz * u, qz);
  }
  const M inAB = (vc <= zero) & (d1 >= zero) & (d3 <= zero);
  {
    const V u = d1 / (d1 - d3);
    qx = select(inAB, ax + abx * u, qx);
    qy = select(inAB, ay + aby * u, qy);
    qz = select(inAB, az + abz * u, qz);
  }
  const M atC = (d6 >= zero) & (d5 <= d6);
  qx = select(atC, cx, qx), qy = select(atC, cy, qy), qz = select(atC, cz, qz);
  const M atB = (d3 >= zero) & (d4 <= d3);
  qx = select(atB, bx, qx), qy = select(atB, by, qy), qz = select(atB, bz, qz);
  const M atA = (d1 <= zero) & (d2 <= zero);
  qx = select(atA, ax, qx), qy = select(atA, ay, qy), qz = select(atA, az, qz);
  const V ex = p.x - qx, ey = p.y - qy, ez = p.z - qz;
  return dot3(ex, ey, ez, ex, ey, ez);
}

template <class V>
V primitiveFieldV(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                  Vec3V<V> p) {
  if (prim.meta.y != 0u) p = toLocal(program.matrices[prim.meta.y], p);
  const V zero(0.0f), one(1.0f);
  const V dx = p.x - V(prim.p0.x), dy = p.y - V(prim.p0.y), dz = p.z - V(prim.p0.z);
  const V nx(prim.p1.x), ny(prim.p1.y), nz(prim.p1.z);
  V dd = zero;
  switch (prim.meta.x) {
    case layout::PRIM_POINT:
      dd = dot3(dx, dy, dz, dx, dy, dz);
      break;
    case layout::PRIM_LINE: {
      const V raw = dot3(dx, dy, dz, nx, ny, nz) * V(prim.p1.w);
      // std::clamp(v, 0, 1) = v < 0 ? 0 : (1 < v ? 1 : v)
      const V t = select(raw < zero, zero, select(one < raw, one, raw));
      const V ex = dx - nx * t, ey = dy - ny * t, ez = dz - nz * t;
      dd = dot3(ex, ey, ez, ex, ey, ez);
      break;
    }
    case layout::PRIM_CYLINDER: {
      const V y = dot3(dx, dy, dz, nx, ny, nz);
      const V r2 = vmax(dot3(dx, dy, dz, dx, dy, dz) - y * y, zero);
      const V x = vmax(vsqrt(r2) - V(prim.p2.x), zero);
      const V h = vmax(vmax(-y, y - V(prim.p2.y)), zero);
      dd = x * x + h * h;
      break;
    }
    case layout::PRIM_DISC: {
      const V y = dot3(dx, dy, dz, nx, ny, nz);
      const V r2 = vmax(dot3(dx, dy, dz, dx, dy, dz) - y * y, zero);
      const V radial = vmax(vsqrt(r2) - V(prim.p2.x), zero);
      dd = radial * radial + y * y;
      break;
    }
    case layout::PRIM_RING: {
      const V y = dot3(dx, dy, dz, nx, ny, nz);
      const V r2 = vmax(dot3(dx, dy, dz, dx, dy, dz) - y * y, zero);
      const V radial = vsqrt(r2) - V(prim.p2.x);
      dd = radial * radial + y * y;
      break;
    }
    case layout::PRIM_CUBE: {
      const V ex = vmax(vabs(dx) - nx, zero), ey = vmax(vabs(dy) - ny, zero),
              ez = vmax(vabs(dz) - nz, zero);
      dd = dot3(ex, ey, ez, ex, ey, ez);
      break;
    }
    case layout::PRIM_TRIANGLE:
      dd = triangleDd(p, prim);
      break;
    case layout::PRIM_QUADRIC: {
      dd = dot3(dx, dy, dz, dx, dy, dz);
      const V t = one - dd;
      return select(dd < one, V(prim.p0.w) * t * t, zero);
    }
    default:
      return zero;
  }
  return wyvillV(dd);
}

// Warps need sin/cos; each lane calls the same libm functions as the reference (correctness
// first: warps are rare in scenes and this keeps their fields bit-identical too).
template <class V>
Vec3V<V> applyWarpV(const blobtree::Program& program, const layout::WarpRecord& warp,
                    Vec3V<V> pv) {
  if (warp.meta.w != 0u) pv = toLocal(program.matrices[warp.meta.w], pv);
  alignas(64) float lanes[3][V::W];
  V::store(lanes[0], pv.x);
  V::store(lanes[1], pv.y);
  V::store(lanes[2], pv.z);
  const std::uint32_t a = warp.meta.y, b = warp.meta.z;
  const float k = warp.params.x;
  for (int l = 0; l < V::W; ++l) {
    float p[3] = {lanes[0][l], lanes[1][l], lanes[2][l]};
    switch (warp.meta.x) {
      case layout::WARP_TWIST: {
        const std::uint32_t u = (a + 1u) % 3u, v = (a + 2u) % 3u;
        const float theta = k * p[a];
        const float c = std::cos(theta), s = std::sin(theta);
        const float pu = p[u], pw = p[v];
        p[u] = pu * c - pw * s;
        p[v] = pu * s + pw * c;
        break;
      }
      case layout::WARP_TAPER:
        p[b] = p[b] * (1.0f + k * p[a]);
        break;
      case layout::WARP_SHEAR:
        p[a] = p[a] + k * p[b];
        break;
      case layout::WARP_BEND: {
        if (k == 0.0f) break;
        const float y = p[a], z = p[b];
        const float yc = std::clamp(y, warp.params.z, warp.params.w);
        const float theta = k * (yc - warp.params.y);
        const float c = std::cos(theta), s = std::sin(theta);
        const float invK = 1.0f / k;
        const float beyond = y - yc;
        p[a] = -s * (z - invK) + warp.params.y + c * beyond;
        p[b] = c * (z - invK) + invK + s * beyond;
        break;
      }
      default:
        break;
    }
    lanes[0][l] = p[0], lanes[1][l] = p[1], lanes[2][l] = p[2];
  }
  return {V::load(lanes[0]), V::load(lanes[1]), V::load(lanes[2])};
}

template <class V>
V powV(const V& base, float exponent) {
  alignas(64) float lanes[V::W];
  V::store(lanes, vmax(base, V(0.0f)));
  for (int l = 0; l < V::W; ++l) lanes[l] = std::pow(lanes[l], exponent);
  return V::load(lanes);
}

// One block of V::W points. Registers live in the caller's frame; a taken skip for only some
// lanes evaluates the subtree for all and zeroes the skipped lanes where the subtree ends.
template <class V, bool kColour>
void runBlock(const blobtree::Program& program, const Vec3V<V>& p, V& outField, V* outColour) {
  using M = typename V::Mask;
  V reg[layout::MAX_FIELD_REGISTERS];
  V cr[kColour ? layout::MAX_FIELD_REGISTERS : 1], cg[kColour ? layout::MAX_FIELD_REGISTERS : 1],
      cb[kColour ? layout::MAX_FIELD_REGISTERS : 1];
  Vec3V<V> pts[layout::MAX_POINT_REGISTERS];
  pts[0] = p;
  // Pending partial skips: at instruction `target`, lanes in `out` get 0 in register `dst`.
  struct Pending {
    std::uint32_t target, dst;
    M out;
  };
  struct Frame {
    Pending skip;
    M enclosingActive;
  };
  // Nesting depth is bounded by the code length; the stack is per thread and grows once.
  thread_local std::vector<Frame> stack;
  if (stack.size() < program.code.size() + 1) stack.resize(program.code.size() + 1);
  Frame* frames = stack.data();
  int pendingCount = 0;
  M active = ~M::none();  // lanes not yet known to be skipped by an enclosing pending skip
  const V zero(0.0f), one(1.0f);
  const std::size_t n = program.code.size();
  const layout::Instruction* code = program.code.data();
  std::size_t pc = 0;
  for (;;) {
    while (pendingCount > 0 && frames[pendingCount - 1].skip.target <= pc) {
      --pendingCount;
      const Pending& s = frames[pendingCount].skip;
      reg[s.dst] = select(s.out, zero, reg[s.dst]);
      if constexpr (kColour) {
        cr[s.dst] = select(s.out, zero, cr[s.dst]);
        cg[s.dst] = select(s.out, zero, cg[s.dst]);
        cb[s.dst] = select(s.out, zero, cb[s.dst]);
      }
      active = frames[pendingCount].enclosingActive;
    }
    if (pc >= n) break;
    const layout::uvec4 in = code[pc].code;
    const std::uint32_t op = in.x & 0xffu;
    const std::uint32_t dst = in.x >> 8;
    switch (op) {
      case layout::OP_PRIM: {
        const auto& prim = program.primitives[in.y];
        reg[dst] = primitiveFieldV<V>(program, prim, pts[in.z]);
        if constexpr (kColour) {
          const std::uint32_t rgba = prim.meta.z;
          cr[dst] = V(float(rgba & 0xffu) / 255.0f);
          cg[dst] = V(float((rgba >> 8) & 0xffu) / 255.0f);
          cb[dst] = V(float((rgba >> 16) & 0xffu) / 255.0f);
        }
        break;
      }
      case layout::OP_ADD: {
        const V a = reg[dst], b = reg[in.y];
        if constexpr (kColour) {
          const V wa = vmax(a, zero), wb = vmax(b, zero);
          const V w = wa + wb;
          const M m = w > zero;
          cr[dst] = select(m, (cr[dst] * wa + cr[in.y] * wb) / w, cr[dst]);
          cg[dst] = select(m, (cg[dst] * wa + cg[in.y] * wb) / w, cg[dst]);
          cb[dst] = select(m, (cb[dst] * wa + cb[in.y] * wb) / w, cb[dst]);
        }
        reg[dst] = a + b;
        break;
      }
      case layout::OP_MAX:
        if constexpr (kColour) {
          const M m = reg[in.y] > reg[dst];
          cr[dst] = select(m, cr[in.y], cr[dst]);
          cg[dst] = select(m, cg[in.y], cg[dst]);
          cb[dst] = select(m, cb[in.y], cb[dst]);
        }
        reg[dst] = vmax(reg[dst], reg[in.y]);
        break;
      case layout::OP_MIN:
      case layout::OP_MUL:
        if constexpr (kColour) {
          const M m = reg[in.y] < reg[dst];
          cr[dst] = select(m, cr[in.y], cr[dst]);
          cg[dst] = select(m, cg[in.y], cg[dst]);
          cb[dst] = select(m, cb[in.y], cb[dst]);
        }
        reg[dst] = op == layout::OP_MIN ? vmin(reg[dst], reg[in.y]) : reg[dst] * reg[in.y];
        break;
      case layout::OP_DIFF:
      case layout::OP_SDIFF: {
        const V cut = one - reg[in.y];
        if constexpr (kColour) {
          const M m = cut < reg[dst];
          cr[dst] = select(m, cr[in.y], cr[dst]);
          cg[dst] = select(m, cg[in.y], cg[dst]);
          cb[dst] = select(m, cb[in.y], cb[dst]);
        }
        reg[dst] = op == layout::OP_DIFF ? vmin(reg[dst], cut) : reg[dst] * cut;
        break;
      }
      case layout::OP_ONE_MINUS:
        reg[dst] = one - reg[dst];
        break;
      case layout::OP_POW:
        reg[dst] = powV(reg[dst], std::bit_cast<float>(in.w));
        break;
      case layout::OP_WARP:
        pts[dst] = applyWarpV<V>(program, program.warps[in.y], pts[in.z]);
        break;
      case layout::OP_SKIP: {
        const layout::BoxRecord& box = program.boxes[in.y];
        const Vec3V<V>& q = pts[in.z];
        const M out = (q.x < V(box.lo.x)) | (q.y < V(box.lo.y)) | (q.z < V(box.lo.z)) |
                      (q.x > V(box.hi.x)) | (q.y > V(box.hi.y)) | (q.z > V(box.hi.z));
        if (all(out | ~active)) {
          reg[dst] = zero;
          if constexpr (kColour) cr[dst] = zero, cg[dst] = zero, cb[dst] = zero;
          pc = in.w;
          continue;
        }
        if (any(out)) {
          frames[pendingCount++] = {{in.w, dst, out}, active};
          active = active & ~out;
        }
        break;
      }
      default:
        break;
    }
    ++pc;
  }
  outField = n ? reg[0] : zero;
  if constexpr (kColour) {
    if (n) {
      outColour[0] = cr[0], outColour[1] = cg[0], outColour[2] = cb[0];
    } else {
      outColour[0] = outColour[1] = outColour[2] = zero;
    }
  }
}

// Any n: full blocks straight from the arrays, the tail padded by repeating the last point.
template <class V>
void evaluateArrays(const blobtree::Program& program, const float* x, const float* y,
                    const float* z, float* field, float* r, float* g, float* b, std::size_t n) {
  const bool colour = r != nullptr;
  std::size_t i = 0;
  auto one = [&](const Vec3V<V>& p, float* f, float* cr, float* cg, float* cb) {
    V fv(0.0f);
    if (colour) {
      V c[3] = {V(0.0f), V(0.0f), V(0.0f)};
      runBlock<V, true>(program, p, fv, c);
      V::storeu(cr, c[0]);
      V::storeu(cg, c[1]);
      V::storeu(cb, c[2]);
    } else {
      runBlock<V, false>(program, p, fv, nullptr);
    }
    V::storeu(f, fv);
  };
  for (; i + V::W <= n; i += V::W) {
    const Vec3V<V> p{V::loadu(x + i), V::loadu(y + i), V::loadu(z + i)};
    one(p, field + i, colour ? r + i : nullptr, colour ? g + i : nullptr, colour ? b + i : nullptr);
  }
  if (i < n) {
    alignas(64) float t[7][V::W];
    for (int l = 0; l < V::W; ++l) {
      const std::size_t s = std::min(i + std::size_t(l), n - 1);
      t[0][l] = x[s], t[1][l] = y[s], t[2][l] = z[s];
    }
    one({V::load(t[0]), V::load(t[1]), V::load(t[2])}, t[3], t[4], t[5], t[6]);
    for (std::size_t l = 0; i + l < n; ++l) {
      field[i + l] = t[3][l];
      if (colour) r[i + l] = t[4][l], g[i + l] = t[5][l], b[i + l] = t[6][l];
    }
  }
}

}  // namespace blobvk::cpu::detail
