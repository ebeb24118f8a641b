// Internal: the analytic-gradient evaluator over a lane type V (the lane types of simd_avx2.cpp
// and simd_avx512.cpp; include after simd_kernel_impl.h). Every formula mirrors
// blobtree/evaluate_gradient.cpp operation for operation and in the same order, so each lane
// computes the field, gradient and colour bits of blobtree::evaluateGradient(Colour). Chunks of K
// blocks share each instruction's decode, as in runBlocks.
#pragma once

#include "blobvk/blobtree/gradient.h"
#include "blobvk/cpu_simd/simd_kernel_impl.h"

namespace blobvk::cpu::detail {

// One primitive of type Type (a compile-time constant, so the switch folds away; forced inline so
// primitiveGradientK's per-type loops keep the record's broadcasts out of the block loop): field,
// and its gradient in the primitive's input space (g).
template <class V, std::uint32_t Type>
[[gnu::always_inline]] inline V primitiveGradientOfType(const blobtree::Program& program, const layout::PrimitiveRecord& prim,
                                                        Vec3V<V> p, Vec3V<V>& g) {
  const bool matrix = prim.meta.y != 0u;
  if (matrix) p = toLocal(program.matrices[prim.meta.y], p);
  const V zero(0.0f), one(1.0f), two(2.0f);
  const V dx = p.x - V(prim.p0.x), dy = p.y - V(prim.p0.y), dz = p.z - V(prim.p0.z);
  const V nx(prim.p1.x), ny(prim.p1.y), nz(prim.p1.z);
  V dd = zero;
  Vec3V<V> dg{zero, zero, zero};  // gradient of dd
  V field;
  switch (Type) {
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
      constexpr bool disc = Type == layout::PRIM_DISC;
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

// The primitive at K blocks of points: one dispatch on its type for all of them.
template <class V, int K>
void primitiveGradientK(const blobtree::Program& program, const layout::PrimitiveRecord& prim, const Vec3V<V>* p,
                        V* field, Vec3V<V>* g) {
#define BLOBVK_GRADIENT_CASE(T)                                                                          \
  case T:                                                                                                \
    for (int b = 0; b < K; ++b) field[b] = primitiveGradientOfType<V, T>(program, prim, p[b], g[b]); \
    return;
  switch (prim.meta.x) {
    BLOBVK_GRADIENT_CASE(layout::PRIM_POINT)
    BLOBVK_GRADIENT_CASE(layout::PRIM_LINE)
    BLOBVK_GRADIENT_CASE(layout::PRIM_CYLINDER)
    BLOBVK_GRADIENT_CASE(layout::PRIM_DISC)
    BLOBVK_GRADIENT_CASE(layout::PRIM_RING)
    BLOBVK_GRADIENT_CASE(layout::PRIM_CUBE)
    BLOBVK_GRADIENT_CASE(layout::PRIM_TRIANGLE)
    BLOBVK_GRADIENT_CASE(layout::PRIM_QUADRIC)
    default:
      for (int b = 0; b < K; ++b) field[b] = V(0.0f), g[b] = {V(0.0f), V(0.0f), V(0.0f)};
      return;
  }
#undef BLOBVK_GRADIENT_CASE
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

// A primitive type that no evaluator knows (tape_pruning's null twins) evaluates to exactly +0,
// gradient +0 (primitiveGradientK's default).
inline bool zeroPrimitiveType(std::uint32_t type) {
  switch (type) {
    case layout::PRIM_POINT:
    case layout::PRIM_LINE:
    case layout::PRIM_CYLINDER:
    case layout::PRIM_DISC:
    case layout::PRIM_RING:
    case layout::PRIM_CUBE:
    case layout::PRIM_TRIANGLE:
    case layout::PRIM_QUADRIC:
      return false;
    default:
      return true;
  }
}

// Colour tapes (tape_pruning.h) keep every add of a blend, so a blend of many primitives of which
// few reach an MPU runs long chains of "r = null twin; d += r" at its vertices. Each such pair
// does the same thing to register d: the twin's field and gradient are +0 (no point register,
// so no Jacobian product) and its colour, finite and >= 0, enters only as colour * +0 = +0. So
// the chain is one function T applied again and again; T is not the identity (c * w / w rounds),
// but once an application leaves d's bits unchanged every later one does too, and the rest of the
// chain can go (in practice after the second). Returns the number of such pairs from pc on, all
// before `end`, with the same r and d.
inline std::size_t nullAddRun(const blobtree::Program& program, std::size_t pc, std::size_t end,
                              std::uint32_t regs) {
  const auto& code = program.code;
  const std::uint32_t r = code[pc].code.x >> 8;
  if (pc + 1 >= end) return 0;
  const std::uint32_t d = code[pc + 1].code.x >> 8;
  if (r >= regs || d >= regs || r == d) return 0;
  std::size_t pairs = 0;
  for (std::size_t j = pc; j + 1 < end; j += 2, ++pairs) {
    const layout::uvec4 p = code[j].code, a = code[j + 1].code;
    const bool nullPrim = (p.x & 0xffu) == layout::OP_PRIM && (p.x >> 8) == r && p.z == 0u &&
                          p.y < program.primitives.size() &&
                          zeroPrimitiveType(program.primitives[p.y].meta.x);
    const bool addIt = (a.x & 0xffu) == layout::OP_ADD && (a.x >> 8) == d && a.y == r;
    if (!nullPrim || !addIt) break;
  }
  return pairs;
}

// K blocks of V::W points: field, gradient and (kColour) colour, as blobtree::run<kColour> in
// evaluate_gradient.cpp. Each instruction is decoded once for the K blocks (as runBlocks does).
// Skips as in runBlocks: all active lanes outside -> jump; some -> zero those lanes' register,
// gradient and colour at the skip's target.
template <class V, bool kColour, int K>
void runGradientBlocks(const blobtree::Program& program, const Vec3V<V>* p, V (*out)[7]) {
  using M = typename V::Mask;
  constexpr std::size_t kC = kColour ? layout::MAX_FIELD_REGISTERS : 1;
  const std::uint32_t regs = std::max<std::uint32_t>(program.fieldRegisters, 1);
  V reg[layout::MAX_FIELD_REGISTERS][K];
  Vec3V<V> grad[layout::MAX_FIELD_REGISTERS][K];
  V cr[kC][K], cg[kC][K], cb[kC][K];
  Vec3V<V> pts[layout::MAX_POINT_REGISTERS][K];
  JacobianV<V> jac[layout::MAX_POINT_REGISTERS][K];
  const V zero(0.0f), one(1.0f);
  for (int b = 0; b < K; ++b) pts[0][b] = p[b];
  if (program.pointRegisters > 1)
    for (std::uint32_t r = 0; r < program.pointRegisters && r < layout::MAX_POINT_REGISTERS; ++r)
      for (int b = 0; b < K; ++b)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) jac[r][b].m[i][j] = i == j ? one : zero;
  struct Frame {
    std::uint32_t target, dst;
    M out[K], enclosingActive[K];
  };
  thread_local std::vector<Frame> stack;
  if (stack.size() < program.code.size() + 1) stack.resize(program.code.size() + 1);
  Frame* frames = stack.data();
  int pending = 0;
  M active[K];
  for (int b = 0; b < K; ++b) active[b] = ~M::none();
  const std::size_t n = program.code.size();
  std::size_t stop = n, pc = 0;
  const auto pick = [](M m, const Vec3V<V>& a, const Vec3V<V>& c) {
    return Vec3V<V>{select(m, a.x, c.x), select(m, a.y, c.y), select(m, a.z, c.z)};
  };
  const auto primColour = [](std::uint32_t rgba, V& r, V& g, V& b) {
    r = V(float(rgba & 0xffu) / 255.0f), g = V(float((rgba >> 8) & 0xffu) / 255.0f);
    b = V(float((rgba >> 16) & 0xffu) / 255.0f);
  };
  // d += s for block b: the blend's colour weighted by the clamped fields, field and gradient summed.
  const auto addBlock = [&](std::uint32_t d, std::uint32_t s, int b) {
    const V a = reg[d][b], c = reg[s][b];
    if constexpr (kColour) {
      const V wa = vmax(a, zero), wb = vmax(c, zero);
      const V w = wa + wb;
      const M m = w > zero;
      cr[d][b] = select(m, (cr[d][b] * wa + cr[s][b] * wb) / w, cr[d][b]);
      cg[d][b] = select(m, (cg[d][b] * wa + cg[s][b] * wb) / w, cg[d][b]);
      cb[d][b] = select(m, (cb[d][b] * wa + cb[s][b] * wb) / w, cb[d][b]);
    }
    reg[d][b] = a + c;
    grad[d][b] = {grad[d][b].x + grad[s][b].x, grad[d][b].y + grad[s][b].y, grad[d][b].z + grad[s][b].z};
  };
  for (;;) {
    while (pc >= stop && pending > 0) {
      const Frame& f = frames[--pending];
      for (int b = 0; b < K; ++b) {
        reg[f.dst][b] = select(f.out[b], zero, reg[f.dst][b]);
        grad[f.dst][b] = pick(f.out[b], {zero, zero, zero}, grad[f.dst][b]);
        if constexpr (kColour) {
          cr[f.dst][b] = select(f.out[b], zero, cr[f.dst][b]);
          cg[f.dst][b] = select(f.out[b], zero, cg[f.dst][b]);
          cb[f.dst][b] = select(f.out[b], zero, cb[f.dst][b]);
        }
        active[b] = f.enclosingActive[b];
      }
      stop = pending > 0 ? std::min<std::size_t>(n, frames[pending - 1].target) : n;
    }
    if (pc >= n) break;
    const layout::uvec4 in = program.code[pc].code;
    const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
    const std::uint32_t src = in.y < regs ? in.y : 0;
    switch (op) {
      case layout::OP_PRIM: {
        if constexpr (kColour) {
          const std::size_t pairs = nullAddRun(program, pc, stop, regs);
          if (pairs > 1) {
            // The last twin leaves r as it would have; then T until it changes no bit.
            const std::uint32_t r = dst, d = program.code[pc + 1].code.x >> 8;
            const std::uint32_t rgba = program.primitives[program.code[pc + 2 * (pairs - 1)].code.y].meta.z;
            for (int b = 0; b < K; ++b) {
              reg[r][b] = zero;
              grad[r][b] = {zero, zero, zero};
              primColour(rgba, cr[r][b], cg[r][b], cb[r][b]);
            }
            for (std::size_t i = 0; i < pairs; ++i) {
              bool unchanged = true;
              for (int b = 0; b < K; ++b) {
                const V f0 = reg[d][b], r0 = cr[d][b], g0 = cg[d][b], b0 = cb[d][b];
                const Vec3V<V> n0 = grad[d][b];
                addBlock(d, r, b);
                unchanged = unchanged && sameBits(reg[d][b], f0) && sameBits(cr[d][b], r0) &&
                            sameBits(cg[d][b], g0) && sameBits(cb[d][b], b0) && sameBits(grad[d][b].x, n0.x) &&
                            sameBits(grad[d][b].y, n0.y) && sameBits(grad[d][b].z, n0.z);
              }
              if (unchanged) break;
            }
            pc += 2 * pairs;
            continue;
          }
        }
        const auto& prim = program.primitives[in.y];
        Vec3V<V> gk[K];
        primitiveGradientK<V, K>(program, prim, pts[in.z], reg[dst], gk);
        for (int b = 0; b < K; ++b) {
          Vec3V<V> g = gk[b];
          if (in.z != 0u) {
            const JacobianV<V>& j = jac[in.z][b];
            g = {j.m[0][0] * g.x + j.m[1][0] * g.y + j.m[2][0] * g.z, j.m[0][1] * g.x + j.m[1][1] * g.y + j.m[2][1] * g.z,
                 j.m[0][2] * g.x + j.m[1][2] * g.y + j.m[2][2] * g.z};
          }
          grad[dst][b] = g;
        }
        if constexpr (kColour)
          for (int b = 0; b < K; ++b) primColour(prim.meta.z, cr[dst][b], cg[dst][b], cb[dst][b]);
        break;
      }
      case layout::OP_ADD:
        for (int b = 0; b < K; ++b) addBlock(dst, src, b);
        break;
      case layout::OP_MAX:
      case layout::OP_MIN:
      case layout::OP_DIFF:
        for (int b = 0; b < K; ++b) {
          const V other = op == layout::OP_DIFF ? one - reg[src][b] : reg[src][b];
          const M m = op == layout::OP_MAX ? other > reg[dst][b] : other < reg[dst][b];
          if constexpr (kColour) {
            cr[dst][b] = select(m, cr[src][b], cr[dst][b]);
            cg[dst][b] = select(m, cg[src][b], cg[dst][b]);
            cb[dst][b] = select(m, cb[src][b], cb[dst][b]);
          }
          const Vec3V<V>& gs = grad[src][b];
          const Vec3V<V> og = op == layout::OP_DIFF ? Vec3V<V>{-gs.x, -gs.y, -gs.z} : gs;
          grad[dst][b] = pick(m, og, grad[dst][b]);
          reg[dst][b] = op == layout::OP_MAX ? vmax(reg[dst][b], other) : vmin(reg[dst][b], other);
        }
        break;
      case layout::OP_SDIFF:
      case layout::OP_MUL:
        for (int b = 0; b < K; ++b) {
          const V other = op == layout::OP_SDIFF ? one - reg[src][b] : reg[src][b];
          if constexpr (kColour) {
            const M m = other < reg[dst][b];
            cr[dst][b] = select(m, cr[src][b], cr[dst][b]);
            cg[dst][b] = select(m, cg[src][b], cg[dst][b]);
            cb[dst][b] = select(m, cb[src][b], cb[dst][b]);
          }
          const V a = reg[dst][b];
          const Vec3V<V> ga = grad[dst][b], gb = grad[src][b];
          // SDIFF: ga (1 - b) - gb a; MUL: ga b + gb a.
          if (op == layout::OP_SDIFF)
            grad[dst][b] = {ga.x * other - gb.x * a, ga.y * other - gb.y * a, ga.z * other - gb.z * a};
          else
            grad[dst][b] = {ga.x * other + gb.x * a, ga.y * other + gb.y * a, ga.z * other + gb.z * a};
          reg[dst][b] = a * other;
        }
        break;
      case layout::OP_ONE_MINUS:
        for (int b = 0; b < K; ++b) {
          reg[dst][b] = one - reg[dst][b];
          grad[dst][b] = {-grad[dst][b].x, -grad[dst][b].y, -grad[dst][b].z};
        }
        break;
      case layout::OP_POW:
        for (int b = 0; b < K; ++b) {
          V d;
          reg[dst][b] = powDerivativeV(reg[dst][b], std::bit_cast<float>(in.w), d);
          grad[dst][b] = {grad[dst][b].x * d, grad[dst][b].y * d, grad[dst][b].z * d};
        }
        break;
      case layout::OP_WARP:
        for (int b = 0; b < K; ++b)
          applyWarpJacobianV(program, program.warps[in.y], pts[in.z][b], jac[in.z][b], pts[dst][b], jac[dst][b]);
        break;
      case layout::OP_SKIP: {
        const layout::BoxRecord& box = program.boxes[in.y];
        const V lx(box.lo.x), ly(box.lo.y), lz(box.lo.z), hx(box.hi.x), hy(box.hi.y), hz(box.hi.z);
        M outside[K];
        bool allOut = true, anyOut = false;
        for (int b = 0; b < K; ++b) {
          const Vec3V<V>& q = pts[in.z][b];
          outside[b] = (q.x < lx) | (q.y < ly) | (q.z < lz) | (q.x > hx) | (q.y > hy) | (q.z > hz);
          allOut = allOut && all(outside[b] | ~active[b]);
          anyOut = anyOut || any(outside[b]);
        }
        if (allOut) {
          for (int b = 0; b < K; ++b) {
            reg[dst][b] = zero;
            grad[dst][b] = {zero, zero, zero};
            if constexpr (kColour) cr[dst][b] = zero, cg[dst][b] = zero, cb[dst][b] = zero;
          }
          pc = in.w;
          continue;
        }
        if (anyOut) {
          Frame& f = frames[pending++];
          f.target = in.w, f.dst = dst;
          for (int b = 0; b < K; ++b) {
            f.out[b] = outside[b];
            f.enclosingActive[b] = active[b];
            active[b] = active[b] & ~outside[b];
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
  const bool any = n != 0;
  for (int b = 0; b < K; ++b) {
    out[b][0] = any ? reg[0][b] : zero;
    out[b][1] = any ? grad[0][b].x : zero, out[b][2] = any ? grad[0][b].y : zero, out[b][3] = any ? grad[0][b].z : zero;
    if constexpr (kColour) out[b][4] = any ? cr[0][b] : zero, out[b][5] = any ? cg[0][b] : zero, out[b][6] = any ? cb[0][b] : zero;
  }
}

// Any n: chunks of kChunkBlocks blocks (as the field kernel), then single blocks; the tail
// padded by repeating the last point.
template <class V, int K>
void gradientChunk(const blobtree::Program& program, const float* x, const float* y, const float* z,
                   float* const* outputs, bool colour, std::size_t i, std::size_t n) {
  Vec3V<V> p[K];
  for (int k = 0; k < K; ++k) {
    alignas(64) float in[3][V::W];
    for (int l = 0; l < V::W; ++l) {
      const std::size_t s = std::min(i + std::size_t(k) * V::W + std::size_t(l), n - 1);
      in[0][l] = x[s], in[1][l] = y[s], in[2][l] = z[s];
    }
    p[k] = {V::load(in[0]), V::load(in[1]), V::load(in[2])};
  }
  V out[K][7];
  if (colour)
    runGradientBlocks<V, true, K>(program, p, out);
  else
    runGradientBlocks<V, false, K>(program, p, out);
  const int count = colour ? 7 : 4;
  alignas(64) float lanes[V::W];
  for (int k = 0; k < K; ++k)
    for (int o = 0; o < count; ++o) {
      V::store(lanes, out[k][o]);
      const std::size_t base = i + std::size_t(k) * V::W;
      for (std::size_t l = 0; l < std::size_t(V::W) && base + l < n; ++l) outputs[o][base + l] = lanes[l];
    }
}

template <class V>
void evaluateGradientArrays(const blobtree::Program& program, const float* x, const float* y, const float* z,
                            float* const* outputs, bool colour, std::size_t n) {
  constexpr int K = kChunkBlocks<V>;
  constexpr std::size_t chunk = std::size_t(K) * V::W;
  std::size_t i = 0;
  for (; i + chunk <= n; i += chunk) gradientChunk<V, K>(program, x, y, z, outputs, colour, i, n);
  for (; i < n; i += V::W) gradientChunk<V, 1>(program, x, y, z, outputs, colour, i, n);
}

}  // namespace blobvk::cpu::detail
