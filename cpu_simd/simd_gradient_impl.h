// Internal: the analytic-gradient evaluator over a lane type V (the lane types of simd_avx2.cpp
// and simd_avx512.cpp; include after simd_kernel_impl.h). Every formula mirrors
// blobtree/evaluate_gradient.cpp operation for operation and in the same order, so each lane
// computes the field, gradient and colour bits of blobtree::evaluateGradient(Colour). One block
// of V::W points per pass: gradients are taken at vertices only, a small share of the points.
#pragma once

#include "blobvk/blobtree/gradient.h"
#include "blobvk/cpu_simd/simd_kernel_impl.h"

namespace blobvk::cpu::detail {

// One primitive: field, and its gradient in the primitive's input space (g).
template <class V>
V primitiveGradientV(const blobtree::Program& program, const layout::PrimitiveRecord& prim, Vec3V<V> p, Vec3V<V>& g) {
  const bool matrix = prim.meta.y != 0u;
  if (matrix) p = toLocal(program.matrices[prim.meta.y], p);
  const V zero(0.0f), one(1.0f), two(2.0f);
  const V dx = p.x - V(prim.p0.x), dy = p.y - V(prim.p0.y), dz = p.z - V(prim.p0.z);
  const V nx(prim.p1.x), ny(prim.p1.y), nz(prim.p1.z);
  V dd = zero;
  Vec3V<V> dg{zero, zero, zero};  // gradient of dd
  V field;
  switch (prim.meta.x) {
    case layout::PRIM_POINT:
      dd = dot3(dx, dy, dz, dx, dy, dz);
      dg = {dx * two, dy * two, dz * two};
      break;
    case layout::PRIM_LINE: {
      const V raw = dot3(dx, dy, dz, nx, ny, nz) * V(prim.p1.w);
      const V t = select(raw < zero, zero, select(one < raw, one, raw));
      const V ex = dx - nx * t, ey = dy - ny * t, ez = dz - nz * t;
      dd = dot3(ex, ey, ez, ex, ey, ez);
      dg = {ex * two, ey * two, ez * two};
      break;
    }
    case layout::PRIM_CYLINDER: {
      const V y = dot3(dx, dy, dz, nx, ny, nz);
      const V r2 = vmax(dot3(dx, dy, dz, dx, dy, dz) - y * y, zero);
      const V rl = vsqrt(r2);
      const V x = vmax(rl - V(prim.p2.x), zero);
      const V below = -y, above = y - V(prim.p2.y);
      const V h = vmax(vmax(below, above), zero);
      dd = x * x + h * h;
      const V cx = select(x > zero, two * x / rl, zero);
      const V ch = select(h > zero, select(below < above, two * h, V(-2.0f) * h), zero);
      dg = {(dx - nx * y) * cx + nx * ch, (dy - ny * y) * cx + ny * ch, (dz - nz * y) * cx + nz * ch};
      break;
    }
    case layout::PRIM_DISC:
    case layout::PRIM_RING: {
      const V y = dot3(dx, dy, dz, nx, ny, nz);
      const V r2 = vmax(dot3(dx, dy, dz, dx, dy, dz) - y * y, zero);
      const V rl = vsqrt(r2);
      const bool disc = prim.meta.x == layout::PRIM_DISC;
      const V radial = disc ? vmax(rl - V(prim.p2.x), zero) : rl - V(prim.p2.x);
      dd = radial * radial + y * y;
      const V cr = select(disc ? radial > zero : rl > zero, two * radial / rl, zero);
      const V cy = two * y;
      dg = {(dx - nx * y) * cr + nx * cy, (dy - ny * y) * cr + ny * cy, (dz - nz * y) * cr + nz * cy};
      break;
    }
    case layout::PRIM_CUBE: {
      const V ex = vmax(vabs(dx) - nx, zero), ey = vmax(vabs(dy) - ny, zero), ez = vmax(vabs(dz) - nz, zero);
      dd = dot3(ex, ey, ez, ex, ey, ez);
      const V m2(-2.0f);
      dg = {select(dx < zero, m2 * ex, two * ex), select(dy < zero, m2 * ey, two * ey), select(dz < zero, m2 * ez, two * ez)};
      break;
    }
    case layout::PRIM_TRIANGLE: {
      Vec3V<V> q;
      dd = triangleDd(p, prim, &q);
      dg = {(p.x - q.x) * two, (p.y - q.y) * two, (p.z - q.z) * two};
      break;
    }
    case layout::PRIM_QUADRIC: {
      dd = dot3(dx, dy, dz, dx, dy, dz);
      const V t = one - dd;
      const typename V::Mask in = dd < one;
      const V c = two * (V(-2.0f * prim.p0.w) * t);
      g = {select(in, dx * c, zero), select(in, dy * c, zero), select(in, dz * c, zero)};
      field = select(in, V(prim.p0.w) * t * t, zero);
      if (matrix) g = transposeTimesV(program.matrices[prim.meta.y], g);
      return field;
    }
    default:
      g = {zero, zero, zero};
      return zero;
  }
  const V t = one - dd;
  const typename V::Mask in = dd < one;
  const V c = V(-3.0f) * t * t;
  g = {select(in, dg.x * c, zero), select(in, dg.y * c, zero), select(in, dg.z * c, zero)};
  if (matrix) g = transposeTimesV(program.matrices[prim.meta.y], g);
  return select(in, t * t * t, zero);
}

// A point register's Jacobian (row-major, per lane).
template <class V>
struct JacobianV {
  V m[3][3];
};

// The warp per lane through blobtree::applyWarpJacobian (libm sin/cos as the reference).
template <class V>
void applyWarpJacobianV(const blobtree::Program& program, const layout::WarpRecord& warp, const Vec3V<V>& in,
                        const JacobianV<V>& jin, Vec3V<V>& out, JacobianV<V>& jout) {
  alignas(64) float lanes[12][V::W];
  V::store(lanes[0], in.x), V::store(lanes[1], in.y), V::store(lanes[2], in.z);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) V::store(lanes[3 + 3 * i + j], jin.m[i][j]);
  for (int l = 0; l < V::W; ++l) {
    blobtree::Jacobian3 jac;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) jac.m[i][j] = lanes[3 + 3 * i + j][l];
    const glm::vec3 q = blobtree::applyWarpJacobian(program, warp, {lanes[0][l], lanes[1][l], lanes[2][l]}, jac);
    lanes[0][l] = q.x, lanes[1][l] = q.y, lanes[2][l] = q.z;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) lanes[3 + 3 * i + j][l] = jac.m[i][j];
  }
  out = {V::load(lanes[0]), V::load(lanes[1]), V::load(lanes[2])};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) jout.m[i][j] = V::load(lanes[3 + 3 * i + j]);
}

template <class V>
V powDerivativeV(const V& base, float exponent, V& derivative) {
  alignas(64) float b[V::W], d[V::W];
  V::store(b, base);
  for (int l = 0; l < V::W; ++l) b[l] = blobtree::powDerivative(b[l], exponent, d[l]);
  derivative = V::load(d);
  return V::load(b);
}

// One block of V::W points: field, gradient and (kColour) colour, as blobtree::run<kColour> in
// evaluate_gradient.cpp. Skips as in runBlocks: all active lanes outside -> jump; some -> zero
// those lanes' register, gradient and colour at the skip's target.
template <class V, bool kColour>
void runGradientBlock(const blobtree::Program& program, const Vec3V<V>& p, V* out) {
  using M = typename V::Mask;
  constexpr std::size_t kC = kColour ? layout::MAX_FIELD_REGISTERS : 1;
  V reg[layout::MAX_FIELD_REGISTERS];
  Vec3V<V> grad[layout::MAX_FIELD_REGISTERS];
  V cr[kC], cg[kC], cb[kC];
  Vec3V<V> pts[layout::MAX_POINT_REGISTERS];
  JacobianV<V> jac[layout::MAX_POINT_REGISTERS];
  pts[0] = p;
  const V zero(0.0f), one(1.0f);
  for (auto& j : jac)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) j.m[r][c] = r == c ? one : zero;
  struct Frame {
    std::uint32_t target, dst;
    M out, enclosingActive;
  };
  thread_local std::vector<Frame> stack;
  if (stack.size() < program.code.size() + 1) stack.resize(program.code.size() + 1);
  Frame* frames = stack.data();
  int pending = 0;
  M active = ~M::none();
  const std::size_t n = program.code.size();
  std::size_t stop = n, pc = 0;
  const auto pick = [](M m, const Vec3V<V>& a, const Vec3V<V>& b) {
    return Vec3V<V>{select(m, a.x, b.x), select(m, a.y, b.y), select(m, a.z, b.z)};
  };
  for (;;) {
    while (pc >= stop && pending > 0) {
      const Frame& f = frames[--pending];
      reg[f.dst] = select(f.out, zero, reg[f.dst]);
      grad[f.dst] = pick(f.out, {zero, zero, zero}, grad[f.dst]);
      if constexpr (kColour) {
        cr[f.dst] = select(f.out, zero, cr[f.dst]);
        cg[f.dst] = select(f.out, zero, cg[f.dst]);
        cb[f.dst] = select(f.out, zero, cb[f.dst]);
      }
      active = f.enclosingActive;
      stop = pending > 0 ? std::min<std::size_t>(n, frames[pending - 1].target) : n;
    }
    if (pc >= n) break;
    const layout::uvec4 in = program.code[pc].code;
    const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
    const std::uint32_t src = in.y < layout::MAX_FIELD_REGISTERS ? in.y : 0;
    switch (op) {
      case layout::OP_PRIM: {
        const auto& prim = program.primitives[in.y];
        Vec3V<V> g;
        reg[dst] = primitiveGradientV(program, prim, pts[in.z], g);
        if (in.z != 0u) {
          const JacobianV<V>& j = jac[in.z];
          g = {j.m[0][0] * g.x + j.m[1][0] * g.y + j.m[2][0] * g.z, j.m[0][1] * g.x + j.m[1][1] * g.y + j.m[2][1] * g.z,
               j.m[0][2] * g.x + j.m[1][2] * g.y + j.m[2][2] * g.z};
        }
        grad[dst] = g;
        if constexpr (kColour) {
          const std::uint32_t rgba = prim.meta.z;
          cr[dst] = V(float(rgba & 0xffu) / 255.0f), cg[dst] = V(float((rgba >> 8) & 0xffu) / 255.0f),
          cb[dst] = V(float((rgba >> 16) & 0xffu) / 255.0f);
        }
        break;
      }
      case layout::OP_ADD: {
        const V a = reg[dst], b = reg[src];
        if constexpr (kColour) {
          const V wa = vmax(a, zero), wb = vmax(b, zero);
          const V w = wa + wb;
          const M m = w > zero;
          cr[dst] = select(m, (cr[dst] * wa + cr[src] * wb) / w, cr[dst]);
          cg[dst] = select(m, (cg[dst] * wa + cg[src] * wb) / w, cg[dst]);
          cb[dst] = select(m, (cb[dst] * wa + cb[src] * wb) / w, cb[dst]);
        }
        reg[dst] = a + b;
        grad[dst] = {grad[dst].x + grad[src].x, grad[dst].y + grad[src].y, grad[dst].z + grad[src].z};
        break;
      }
      case layout::OP_MAX:
      case layout::OP_MIN:
      case layout::OP_DIFF: {
        const V other = op == layout::OP_DIFF ? one - reg[src] : reg[src];
        const M m = op == layout::OP_MAX ? other > reg[dst] : other < reg[dst];
        if constexpr (kColour) {
          cr[dst] = select(m, cr[src], cr[dst]);
          cg[dst] = select(m, cg[src], cg[dst]);
          cb[dst] = select(m, cb[src], cb[dst]);
        }
        const Vec3V<V> og = op == layout::OP_DIFF ? Vec3V<V>{-grad[src].x, -grad[src].y, -grad[src].z} : grad[src];
        grad[dst] = pick(m, og, grad[dst]);
        reg[dst] = op == layout::OP_MAX ? vmax(reg[dst], other) : vmin(reg[dst], other);
        break;
      }
      case layout::OP_SDIFF:
      case layout::OP_MUL: {
        const V other = op == layout::OP_SDIFF ? one - reg[src] : reg[src];
        if constexpr (kColour) {
          const M m = other < reg[dst];
          cr[dst] = select(m, cr[src], cr[dst]);
          cg[dst] = select(m, cg[src], cg[dst]);
          cb[dst] = select(m, cb[src], cb[dst]);
        }
        const V a = reg[dst];
        const Vec3V<V>& ga = grad[dst];
        const Vec3V<V>& gb = grad[src];
        // SDIFF: ga (1 - b) - gb a; MUL: ga b + gb a.
        if (op == layout::OP_SDIFF)
          grad[dst] = {ga.x * other - gb.x * a, ga.y * other - gb.y * a, ga.z * other - gb.z * a};
        else
          grad[dst] = {ga.x * other + gb.x * a, ga.y * other + gb.y * a, ga.z * other + gb.z * a};
        reg[dst] = a * other;
        break;
      }
      case layout::OP_ONE_MINUS:
        reg[dst] = one - reg[dst];
        grad[dst] = {-grad[dst].x, -grad[dst].y, -grad[dst].z};
        break;
      case layout::OP_POW: {
        V d;
        reg[dst] = powDerivativeV(reg[dst], std::bit_cast<float>(in.w), d);
        grad[dst] = {grad[dst].x * d, grad[dst].y * d, grad[dst].z * d};
        break;
      }
      case layout::OP_WARP:
        applyWarpJacobianV(program, program.warps[in.y], pts[in.z], jac[in.z], pts[dst], jac[dst]);
        break;
      case layout::OP_SKIP: {
        const layout::BoxRecord& box = program.boxes[in.y];
        const Vec3V<V>& q = pts[in.z];
        const M outside = (q.x < V(box.lo.x)) | (q.y < V(box.lo.y)) | (q.z < V(box.lo.z)) | (q.x > V(box.hi.x)) |
                          (q.y > V(box.hi.y)) | (q.z > V(box.hi.z));
        if (all(outside | ~active)) {
          reg[dst] = zero;
          grad[dst] = {zero, zero, zero};
          if constexpr (kColour) cr[dst] = zero, cg[dst] = zero, cb[dst] = zero;
          pc = in.w;
          continue;
        }
        if (any(outside)) {
          Frame& f = frames[pending++];
          f.target = in.w, f.dst = dst, f.out = outside, f.enclosingActive = active;
          active = active & ~outside;
          stop = std::min<std::size_t>(n, in.w);
        }
        break;
      }
      default:
        break;
    }
    ++pc;
  }
  const bool any = n != 0;
  out[0] = any ? reg[0] : zero;
  out[1] = any ? grad[0].x : zero, out[2] = any ? grad[0].y : zero, out[3] = any ? grad[0].z : zero;
  if constexpr (kColour) out[4] = any ? cr[0] : zero, out[5] = any ? cg[0] : zero, out[6] = any ? cb[0] : zero;
}

// Any n, block by block; the tail padded by repeating the last point. `colour` null: no colour.
template <class V>
void evaluateGradientArrays(const blobtree::Program& program, const float* x, const float* y, const float* z,
                            float* const* outputs, bool colour, std::size_t n) {
  const int count = colour ? 7 : 4;
  for (std::size_t i = 0; i < n; i += V::W) {
    alignas(64) float in[3][V::W];
    for (int l = 0; l < V::W; ++l) {
      const std::size_t s = std::min(i + std::size_t(l), n - 1);
      in[0][l] = x[s], in[1][l] = y[s], in[2][l] = z[s];
    }
    V out[7];
    const Vec3V<V> p{V::load(in[0]), V::load(in[1]), V::load(in[2])};
    if (colour)
      runGradientBlock<V, true>(program, p, out);
    else
      runGradientBlock<V, false>(program, p, out);
    alignas(64) float lanes[V::W];
    for (int o = 0; o < count; ++o) {
      V::store(lanes, out[o]);
      for (std::size_t l = 0; l < std::size_t(V::W) && i + l < n; ++l) outputs[o][i + l] = lanes[l];
    }
  }
}

}  // namespace blobvk::cpu::detail
