// Internal: the evaluator written once over a lane type V (see simd_avx2.cpp, simd_avx512.cpp,
// which define V with intrinsics and include this file). Every formula mirrors
// blobtree/evaluate.cpp operation for operation and in the same order, so each lane computes the
// bits the scalar reference computes. Only ISA-specific files include this header.
//
// V must provide: V::W, V(float) broadcast, V::load/store, + - * /, vmax/vmin with std::max/min
// semantics, vsqrt, vabs, comparisons returning V::Mask, select(mask, a, b), any/all, mask & | ~.
#pragma once

#include "blobvk/blobtree/pow_field.h"
#include "blobvk/blobtree/program.h"

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

// M^T g: a gradient in the matrix's output space taken back to its input space.
template <class V>
inline Vec3V<V> transposeTimesV(const layout::MatrixRecord& m, const Vec3V<V>& g) {
  return {V(m.r0.x) * g.x + V(m.r1.x) * g.y + V(m.r2.x) * g.z, V(m.r0.y) * g.x + V(m.r1.y) * g.y + V(m.r2.y) * g.z,
          V(m.r0.z) * g.x + V(m.r1.z) * g.y + V(m.r2.z) * g.z};
}

template <class V>
inline V wyvillV(const V& dd) {
  const V t = V(1.0f) - dd;
  return select(dd < V(1.0f), t * t * t, V(0.0f));
}

// The squared distance to the triangle; `closest` (when given) receives the closest point.
template <class V>
V triangleDd(const Vec3V<V>& p, const layout::PrimitiveRecord& prim, Vec3V<V>* closest = nullptr) {
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
  if (closest) *closest = {qx, qy, qz};
  const V ex = p.x - qx, ey = p.y - qy, ez = p.z - qz;
  return dot3(ex, ey, ez, ex, ey, ez);
}

// One primitive type (a compile-time constant, so the switch folds away); forced inline so the
// per-type loops in primitiveFieldK keep the record's broadcasts out of the block loop.
template <class V, std::uint32_t Type>
[[gnu::always_inline]] inline V primitiveOfType(const blobtree::Program& program,
                                                const layout::PrimitiveRecord& prim, Vec3V<V> p) {
  if (prim.meta.y != 0u) p = toLocal(program.matrices[prim.meta.y], p);
  const V zero(0.0f), one(1.0f);
  const V dx = p.x - V(prim.p0.x), dy = p.y - V(prim.p0.y), dz = p.z - V(prim.p0.z);
  const V nx(prim.p1.x), ny(prim.p1.y), nz(prim.p1.z);
  V dd = zero;
  switch (Type) {
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

// The primitive at K blocks of points: one dispatch on the type for all of them.
template <class V, int K>
void primitiveFieldK(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                     const Vec3V<V>* p, V* out) {
#define BLOBVK_PRIM_CASE(T)                                                        \
  case T:                                                                          \
    for (int b = 0; b < K; ++b) out[b] = primitiveOfType<V, T>(program, prim, p[b]); \
    return;
  switch (prim.meta.x) {
    BLOBVK_PRIM_CASE(layout::PRIM_POINT)
    BLOBVK_PRIM_CASE(layout::PRIM_LINE)
    BLOBVK_PRIM_CASE(layout::PRIM_CYLINDER)
    BLOBVK_PRIM_CASE(layout::PRIM_DISC)
    BLOBVK_PRIM_CASE(layout::PRIM_RING)
    BLOBVK_PRIM_CASE(layout::PRIM_CUBE)
    BLOBVK_PRIM_CASE(layout::PRIM_TRIANGLE)
    BLOBVK_PRIM_CASE(layout::PRIM_QUADRIC)
    default:
      for (int b = 0; b < K; ++b) out[b] = V(0.0f);
      return;
  }
#undef BLOBVK_PRIM_CASE
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
  for (int l = 0; l < V::W; ++l) lanes[l] = blobtree::powField(lanes[l], exponent);
  return V::load(lanes);
}

// K blocks of V::W points through the code at once: each instruction is decoded once and applied
// to every block (the interpreter's dispatch and the records' broadcasts are paid once per K
// blocks). Per lane the operations are those of the one-point reference, in the same order.
// Skips: when every active lane of all K blocks is outside, jump; when some are, evaluate the
// subtree for all and zero the skipped lanes where the subtree ends.
template <class V, bool kColour, int K>
void runBlocks(const blobtree::Program& program, const Vec3V<V>* p, V* outField, V* outColour) {
  using M = typename V::Mask;
  constexpr std::size_t kC = kColour ? layout::MAX_FIELD_REGISTERS : 1;
  V reg[layout::MAX_FIELD_REGISTERS][K];
  V cr[kC][K], cg[kC][K], cb[kC][K];
  Vec3V<V> pts[layout::MAX_POINT_REGISTERS][K];
  for (int b = 0; b < K; ++b) pts[0][b] = p[b];
  // Pending partial skips: at instruction `target`, lanes in `out` get 0 in register `dst`.
  struct Frame {
    std::uint32_t target, dst;
    M out[K];
    M enclosingActive[K];
  };
  // Nesting depth is bounded by the code length; the stack is per thread and grows once.
  thread_local std::vector<Frame> stack;
  if (stack.size() < program.code.size() + 1) stack.resize(program.code.size() + 1);
  Frame* frames = stack.data();
  int pendingCount = 0;
  M active[K];  // lanes not yet known to be skipped by an enclosing pending skip
  for (int b = 0; b < K; ++b) active[b] = ~M::none();
  const V zero(0.0f), one(1.0f);
  const std::size_t n = program.code.size();
  const layout::Instruction* code = program.code.data();
  // The next pc where something other than the next instruction happens: the end of the code
  // or the innermost pending skip's target (nested skips end no later than enclosing ones).
  std::size_t stop = n;
  std::size_t pc = 0;
  for (;;) {
    while (pc >= stop) {
      if (pendingCount == 0) break;
      --pendingCount;
      const Frame& f = frames[pendingCount];
      for (int b = 0; b < K; ++b) {
        reg[f.dst][b] = select(f.out[b], zero, reg[f.dst][b]);
        if constexpr (kColour) {
          cr[f.dst][b] = select(f.out[b], zero, cr[f.dst][b]);
          cg[f.dst][b] = select(f.out[b], zero, cg[f.dst][b]);
          cb[f.dst][b] = select(f.out[b], zero, cb[f.dst][b]);
        }
        active[b] = f.enclosingActive[b];
      }
      stop = pendingCount > 0 ? std::min<std::size_t>(n, frames[pendingCount - 1].target) : n;
    }
    if (pc >= n) break;
    const layout::uvec4 in = code[pc].code;
    const std::uint32_t op = in.x & 0xffu;
    const std::uint32_t dst = in.x >> 8;
    V* rd = reg[dst];
    const V* rs = reg[in.y < layout::MAX_FIELD_REGISTERS ? in.y : 0];
    switch (op) {
      case layout::OP_PRIM: {
        const auto& prim = program.primitives[in.y];
        primitiveFieldK<V, K>(program, prim, pts[in.z], rd);
        if constexpr (kColour) {
          const std::uint32_t rgba = prim.meta.z;
          const V r(float(rgba & 0xffu) / 255.0f), g(float((rgba >> 8) & 0xffu) / 255.0f),
              bl(float((rgba >> 16) & 0xffu) / 255.0f);
          for (int b = 0; b < K; ++b) cr[dst][b] = r, cg[dst][b] = g, cb[dst][b] = bl;
        }
        break;
      }
      case layout::OP_ADD:
        for (int b = 0; b < K; ++b) {
          const V a = rd[b], c = rs[b];
          if constexpr (kColour) {
            const V wa = vmax(a, zero), wb = vmax(c, zero);
            const V w = wa + wb;
            const M m = w > zero;
            cr[dst][b] = select(m, (cr[dst][b] * wa + cr[in.y][b] * wb) / w, cr[dst][b]);
            cg[dst][b] = select(m, (cg[dst][b] * wa + cg[in.y][b] * wb) / w, cg[dst][b]);
            cb[dst][b] = select(m, (cb[dst][b] * wa + cb[in.y][b] * wb) / w, cb[dst][b]);
          }
          rd[b] = a + c;
        }
        break;
      case layout::OP_MAX:
        for (int b = 0; b < K; ++b) {
          if constexpr (kColour) {
            const M m = rs[b] > rd[b];
            cr[dst][b] = select(m, cr[in.y][b], cr[dst][b]);
            cg[dst][b] = select(m, cg[in.y][b], cg[dst][b]);
            cb[dst][b] = select(m, cb[in.y][b], cb[dst][b]);
          }
          rd[b] = vmax(rd[b], rs[b]);
        }
        break;
      case layout::OP_MIN:
      case layout::OP_MUL:
        for (int b = 0; b < K; ++b) {
          if constexpr (kColour) {
            const M m = rs[b] < rd[b];
            cr[dst][b] = select(m, cr[in.y][b], cr[dst][b]);
            cg[dst][b] = select(m, cg[in.y][b], cg[dst][b]);
            cb[dst][b] = select(m, cb[in.y][b], cb[dst][b]);
          }
          rd[b] = op == layout::OP_MIN ? vmin(rd[b], rs[b]) : rd[b] * rs[b];
        }
        break;
      case layout::OP_DIFF:
      case layout::OP_SDIFF:
        for (int b = 0; b < K; ++b) {
          const V cut = one - rs[b];
          if constexpr (kColour) {
            const M m = cut < rd[b];
            cr[dst][b] = select(m, cr[in.y][b], cr[dst][b]);
            cg[dst][b] = select(m, cg[in.y][b], cg[dst][b]);
            cb[dst][b] = select(m, cb[in.y][b], cb[dst][b]);
          }
          rd[b] = op == layout::OP_DIFF ? vmin(rd[b], cut) : rd[b] * cut;
        }
        break;
      case layout::OP_ONE_MINUS:
        for (int b = 0; b < K; ++b) rd[b] = one - rd[b];
        break;
      case layout::OP_POW:
        for (int b = 0; b < K; ++b) rd[b] = powV(rd[b], std::bit_cast<float>(in.w));
        break;
      case layout::OP_WARP:
        for (int b = 0; b < K; ++b)
          pts[dst][b] = applyWarpV<V>(program, program.warps[in.y], pts[in.z][b]);
        break;
      case layout::OP_SKIP: {
        const layout::BoxRecord& box = program.boxes[in.y];
        const V lx(box.lo.x), ly(box.lo.y), lz(box.lo.z), hx(box.hi.x), hy(box.hi.y), hz(box.hi.z);
        M out[K];
        bool allOut = true, anyOut = false;
        for (int b = 0; b < K; ++b) {
          const Vec3V<V>& q = pts[in.z][b];
          out[b] = (q.x < lx) | (q.y < ly) | (q.z < lz) | (q.x > hx) | (q.y > hy) | (q.z > hz);
          allOut = allOut && all(out[b] | ~active[b]);
          anyOut = anyOut || any(out[b]);
        }
        if (allOut) {
          for (int b = 0; b < K; ++b) {
            rd[b] = zero;
            if constexpr (kColour) cr[dst][b] = zero, cg[dst][b] = zero, cb[dst][b] = zero;
          }
          pc = in.w;
          continue;
        }
        if (anyOut) {
          Frame& f = frames[pendingCount++];
          f.target = in.w, f.dst = dst;
          for (int b = 0; b < K; ++b) {
            f.out[b] = out[b];
            f.enclosingActive[b] = active[b];
            active[b] = active[b] & ~out[b];
          }
          stop = std::min<std::size_t>(n, in.w);
        }
        break;
      }
      default:
        break;
    }
    ++pc;
  }
  for (int b = 0; b < K; ++b) {
    outField[b] = n ? reg[0][b] : zero;
    if constexpr (kColour) {
      outColour[3 * b + 0] = n ? cr[0][b] : zero;
      outColour[3 * b + 1] = n ? cg[0][b] : zero;
      outColour[3 * b + 2] = n ? cb[0][b] : zero;
    }
  }
}

// Any n: chunks of kChunkBlocks blocks, then single blocks, straight from the arrays; the tail
// padded by repeating the last point.
template <class V, int K>
void evaluateBlocks(const blobtree::Program& program, const float* x, const float* y,
                    const float* z, float* field, float* r, float* g, float* b, std::size_t i) {
  Vec3V<V> p[K];
  for (int k = 0; k < K; ++k) {
    const std::size_t o = i + std::size_t(k) * V::W;
    p[k] = {V::loadu(x + o), V::loadu(y + o), V::loadu(z + o)};
  }
  V f[K];
  if (r) {
    V c[3 * K];
    runBlocks<V, true, K>(program, p, f, c);
    for (int k = 0; k < K; ++k) {
      const std::size_t o = i + std::size_t(k) * V::W;
      V::storeu(r + o, c[3 * k]), V::storeu(g + o, c[3 * k + 1]), V::storeu(b + o, c[3 * k + 2]);
    }
  } else {
    runBlocks<V, false, K>(program, p, f, nullptr);
  }
  for (int k = 0; k < K; ++k) V::storeu(field + i + std::size_t(k) * V::W, f[k]);
}

// Blocks per chunk: 64 points (8 AVX2 blocks, 4 AVX-512 blocks; measured better than 32 on the
// tower and random128, see docs/performance.md). More amortises the dispatch further but a chunk
// only jumps over a skipped subtree when all of its points are outside.
template <class V>
inline constexpr int kChunkBlocks = 64 / V::W > 0 ? 64 / V::W : 1;

template <class V>
void evaluateArrays(const blobtree::Program& program, const float* x, const float* y,
                    const float* z, float* field, float* r, float* g, float* b, std::size_t n) {
  constexpr int K = kChunkBlocks<V>;
  constexpr std::size_t chunk = std::size_t(K) * V::W;
  std::size_t i = 0;
  for (; i + chunk <= n; i += chunk) evaluateBlocks<V, K>(program, x, y, z, field, r, g, b, i);
  for (; i + V::W <= n; i += V::W) evaluateBlocks<V, 1>(program, x, y, z, field, r, g, b, i);
  if (i < n) {
    alignas(64) float t[7][V::W];
    for (int l = 0; l < V::W; ++l) {
      const std::size_t s = std::min(i + std::size_t(l), n - 1);
      t[0][l] = x[s], t[1][l] = y[s], t[2][l] = z[s];
    }
    const bool colour = r != nullptr;
    evaluateBlocks<V, 1>(program, t[0], t[1], t[2], t[3], colour ? t[4] : nullptr, t[5], t[6], 0);
    for (std::size_t l = 0; i + l < n; ++l) {
      field[i + l] = t[3][l];
      if (colour) r[i + l] = t[4][l], g[i + l] = t[5][l], b[i + l] = t[6][l];
    }
  }
}

}  // namespace blobvk::cpu::detail
