// Scalar reference of the analytic gradient (see gradient.h). The field value of each primitive
// is computed with the operations of evaluate.cpp, so evaluateGradient(p).field == evaluate(p).
#include "blobvk/blobtree/gradient.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/pow_field.h"
#include "blobvk/blobtree/triangle_closest.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

namespace blobvk::blobtree {
namespace {

using layout::uint;
using glm::vec3;

vec3 xyz(const layout::vec4& v) { return {v.x, v.y, v.z}; }

vec3 toLocal(const layout::MatrixRecord& m, const vec3& p) {
  return {m.r0.x * p.x + m.r0.y * p.y + m.r0.z * p.z + m.r0.w, m.r1.x * p.x + m.r1.y * p.y + m.r1.z * p.z + m.r1.w,
          m.r2.x * p.x + m.r2.y * p.y + m.r2.z * p.z + m.r2.w};
}

// M^T g: a gradient in the matrix's output space taken back to its input space.
vec3 transposeTimes(const layout::MatrixRecord& m, const vec3& g) {
  return {m.r0.x * g.x + m.r1.x * g.y + m.r2.x * g.z, m.r0.y * g.x + m.r1.y * g.y + m.r2.y * g.z,
          m.r0.z * g.x + m.r1.z * g.y + m.r2.z * g.z};
}

vec3 transposeTimes(const Jacobian3& j, const vec3& g) {
  return {j.m[0][0] * g.x + j.m[1][0] * g.y + j.m[2][0] * g.z, j.m[0][1] * g.x + j.m[1][1] * g.y + j.m[2][1] * g.z,
          j.m[0][2] * g.x + j.m[1][2] * g.y + j.m[2][2] * g.z};
}

Jacobian3 times(const Jacobian3& a, const Jacobian3& b) {
  Jacobian3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}

Jacobian3 linearPart(const layout::MatrixRecord& m) {
  Jacobian3 r;
  const layout::vec4* rows[3] = {&m.r0, &m.r1, &m.r2};
  for (int i = 0; i < 3; ++i) r.m[i][0] = rows[i]->x, r.m[i][1] = rows[i]->y, r.m[i][2] = rows[i]->z;
  return r;
}

// Field and gradient (in the primitive's input space) of one primitive. dd and the field follow
// evaluate.cpp's primitiveFieldT<float>; `grad` is dField/dd times the gradient of dd.
float primitiveGradient(const Program& program, const layout::PrimitiveRecord& prim, vec3 p, vec3& grad) {
  const bool matrix = prim.meta.y != 0u;
  if (matrix) p = toLocal(program.matrices[prim.meta.y], p);
  const vec3 p0 = xyz(prim.p0), p1 = xyz(prim.p1);
  float dd = 0.0f;
  vec3 ddGrad(0.0f);  // gradient of dd, before the kernel's derivative
  switch (prim.meta.x) {
    case layout::PRIM_POINT: {
      const vec3 d = p - p0;
      dd = glm::dot(d, d);
      ddGrad = d * 2.0f;
      break;
    }
    case layout::PRIM_LINE: {
      const vec3 d = p - p0;
      const float t = std::clamp(glm::dot(d, p1) * prim.p1.w, 0.0f, 1.0f);
      const vec3 e = d - p1 * t;
      dd = glm::dot(e, e);
      ddGrad = e * 2.0f;  // the closest point moves along the segment: only e's normal part counts
      break;
    }
    case layout::PRIM_CYLINDER: {
      const vec3 d = p - p0;
      const float y = glm::dot(d, p1);
      const float r2 = std::max(glm::dot(d, d) - y * y, 0.0f);
      const float rl = std::sqrt(r2);
      const float x = std::max(rl - prim.p2.x, 0.0f);
      const float below = -y, above = y - prim.p2.y;
      const float h = std::max(std::max(below, above), 0.0f);
      dd = x * x + h * h;
      // d(rl)/dp = radial / rl; d(h)/dp = -axis below the base, +axis above the top.
      const float cx = x > 0.0f ? 2.0f * x / rl : 0.0f;
      const float ch = h > 0.0f ? (below < above ? 2.0f * h : -2.0f * h) : 0.0f;
      ddGrad = (d - p1 * y) * cx + p1 * ch;
      break;
    }
    case layout::PRIM_DISC: {
      const vec3 d = p - p0;
      const float y = glm::dot(d, p1);
      const float r2 = std::max(glm::dot(d, d) - y * y, 0.0f);
      const float rl = std::sqrt(r2);
      const float radial = std::max(rl - prim.p2.x, 0.0f);
      dd = radial * radial + y * y;
      const float cr = radial > 0.0f ? 2.0f * radial / rl : 0.0f;
      ddGrad = (d - p1 * y) * cr + p1 * (2.0f * y);
      break;
    }
    case layout::PRIM_RING: {
      const vec3 d = p - p0;
      const float y = glm::dot(d, p1);
      const float r2 = std::max(glm::dot(d, d) - y * y, 0.0f);
      const float rl = std::sqrt(r2);
      const float radial = rl - prim.p2.x;
      dd = radial * radial + y * y;
      const float cr = rl > 0.0f ? 2.0f * radial / rl : 0.0f;  // on the axis every direction is radial
      ddGrad = (d - p1 * y) * cr + p1 * (2.0f * y);
      break;
    }
    case layout::PRIM_CUBE: {
      const vec3 d = p - p0;
      const vec3 e = glm::max(glm::abs(d) - p1, vec3(0.0f));
      dd = glm::dot(e, e);
      ddGrad = {d.x < 0.0f ? -2.0f * e.x : 2.0f * e.x, d.y < 0.0f ? -2.0f * e.y : 2.0f * e.y,
                d.z < 0.0f ? -2.0f * e.z : 2.0f * e.z};
      break;
    }
    case layout::PRIM_TRIANGLE: {
      const vec3 e = p - detail::triangleClosest<float>(p, p0, p1, xyz(prim.p2));
      dd = glm::dot(e, e);
      ddGrad = e * 2.0f;
      break;
    }
    case layout::PRIM_QUADRIC: {
      const vec3 d = p - p0;
      dd = glm::dot(d, d);
      const float t = 1.0f - dd;
      const bool in = dd < 1.0f;
      // S t^2: d/d(dd) = -2 S t.
      grad = in ? d * (2.0f * (-2.0f * prim.p0.w * t)) : vec3(0.0f);
      if (matrix) grad = transposeTimes(program.matrices[prim.meta.y], grad);
      return in ? prim.p0.w * t * t : 0.0f;
    }
    default:
      grad = vec3(0.0f);
      return 0.0f;
  }
  const float t = 1.0f - dd;
  const bool in = dd < 1.0f;
  grad = in ? ddGrad * (-3.0f * t * t) : vec3(0.0f);  // (1 - dd)^3: d/d(dd) = -3 (1 - dd)^2
  if (matrix) grad = transposeTimes(program.matrices[prim.meta.y], grad);
  return in ? t * t * t : 0.0f;
}

template <bool kColour>
FieldGradient run(const Program& program, const vec3& p) {
  std::array<float, layout::MAX_FIELD_REGISTERS> reg{};
  std::array<vec3, layout::MAX_FIELD_REGISTERS> grad{}, col{};
  std::array<vec3, layout::MAX_POINT_REGISTERS> pts{};
  std::array<Jacobian3, layout::MAX_POINT_REGISTERS> jac{};  // d pts[r] / d p
  pts[0] = p;
  const std::size_t n = program.code.size();
  for (std::size_t pc = 0; pc < n; ++pc) {
    const layout::uvec4 in = program.code[pc].code;
    const uint op = in.x & 0xffu;
    const uint dst = in.x >> 8;
    switch (op) {
      case layout::OP_PRIM: {
        const auto& prim = program.primitives[in.y];
        vec3 g;
        reg[dst] = primitiveGradient(program, prim, pts[in.z], g);
        grad[dst] = in.z == 0u ? g : transposeTimes(jac[in.z], g);  // register 0 is p itself
        if constexpr (kColour) col[dst] = unpackColour(prim.meta.z);
        break;
      }
      case layout::OP_ADD: {
        const float a = reg[dst], b = reg[in.y];
        if constexpr (kColour) {
          const float wa = std::max(a, 0.0f), wb = std::max(b, 0.0f);
          const float w = wa + wb;
          if (w > 0.0f) col[dst] = (col[dst] * wa + col[in.y] * wb) / w;
        }
        reg[dst] = a + b;
        grad[dst] = grad[dst] + grad[in.y];
        break;
      }
      case layout::OP_MAX:
        if (reg[in.y] > reg[dst]) {
          if constexpr (kColour) col[dst] = col[in.y];
          grad[dst] = grad[in.y];
        }
        reg[dst] = std::max(reg[dst], reg[in.y]);
        break;
      case layout::OP_MIN:
        if (reg[in.y] < reg[dst]) {
          if constexpr (kColour) col[dst] = col[in.y];
          grad[dst] = grad[in.y];
        }
        reg[dst] = std::min(reg[dst], reg[in.y]);
        break;
      case layout::OP_DIFF: {
        const float cut = 1.0f - reg[in.y];
        if (cut < reg[dst]) {
          if constexpr (kColour) col[dst] = col[in.y];
          grad[dst] = -grad[in.y];
        }
        reg[dst] = std::min(reg[dst], cut);
        break;
      }
      case layout::OP_SDIFF: {
        const float keep = 1.0f - reg[in.y];
        if constexpr (kColour) {
          if (keep < reg[dst]) col[dst] = col[in.y];
        }
        grad[dst] = grad[dst] * keep - grad[in.y] * reg[dst];
        reg[dst] = reg[dst] * keep;
        break;
      }
      case layout::OP_ONE_MINUS:
        reg[dst] = 1.0f - reg[dst];
        grad[dst] = -grad[dst];
        break;
      case layout::OP_MUL:
        if constexpr (kColour) {
          if (reg[in.y] < reg[dst]) col[dst] = col[in.y];
        }
        grad[dst] = grad[dst] * reg[in.y] + grad[in.y] * reg[dst];
        reg[dst] = reg[dst] * reg[in.y];
        break;
      case layout::OP_POW: {
        float derivative = 0.0f;
        reg[dst] = powDerivative(reg[dst], std::bit_cast<float>(in.w), derivative);
        grad[dst] = grad[dst] * derivative;
        break;
      }
      case layout::OP_WARP: {
        Jacobian3 j = jac[in.z];
        pts[dst] = applyWarpJacobian(program, program.warps[in.y], pts[in.z], j);
        jac[dst] = j;
        break;
      }
      case layout::OP_SKIP: {
        const layout::BoxRecord& box = program.boxes[in.y];
        const vec3& q = pts[in.z];
        if (q.x < box.lo.x || q.y < box.lo.y || q.z < box.lo.z || q.x > box.hi.x || q.y > box.hi.y || q.z > box.hi.z) {
          reg[dst] = 0.0f;
          grad[dst] = vec3(0.0f);
          if constexpr (kColour) col[dst] = vec3(0.0f);
          pc = std::size_t(in.w) - 1;
        }
        break;
      }
      default:
        break;
    }
  }
  if (n == 0) return {};
  return {reg[0], grad[0], kColour ? col[0] : vec3(0.0f)};
}

}  // namespace

float powDerivative(float base, float exponent, float& derivative) {
  const float b = std::max(base, 0.0f);
  const float r = powField(b, exponent);
  // d/db b^e = e b^(e-1) = e r / b (one pow, not two).
  derivative = b > 0.0f ? exponent * r / b : 0.0f;
  return r;
}

vec3 applyWarpJacobian(const Program& program, const layout::WarpRecord& warp, vec3 p, Jacobian3& jacobian) {
  if (warp.meta.w != 0u) {
    const layout::MatrixRecord& m = program.matrices[warp.meta.w];
    p = toLocal(m, p);
    jacobian = times(linearPart(m), jacobian);
  }
  const uint a = warp.meta.y, b = warp.meta.z;
  const float k = warp.params.x;
  Jacobian3 w;  // the warp's own Jacobian at p, identity by default
  switch (warp.meta.x) {
    case layout::WARP_TWIST: {
      const uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
      const float theta = k * p[a];
      const float c = std::cos(theta), s = std::sin(theta);
      const float pu = p[u], pv = p[v];
      p[u] = pu * c - pv * s;
      p[v] = pu * s + pv * c;
      w.m[u][u] = c, w.m[u][v] = -s, w.m[u][a] = -k * p[v];
      w.m[v][u] = s, w.m[v][v] = c, w.m[v][a] = k * p[u];
      break;
    }
    case layout::WARP_TAPER:
      w.m[b][b] = 1.0f + k * p[a];
      w.m[b][a] = k * p[b];
      p[b] = p[b] * (1.0f + k * p[a]);
      break;
    case layout::WARP_SHEAR:
      p[a] = p[a] + k * p[b];
      w.m[a][b] = k;
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
      // Inside the bent region theta follows y (d beyond = 0); past it theta is fixed and the
      // point continues straight (d beyond / dy = 1).
      const bool bent = y > warp.params.z && y < warp.params.w;
      const float dTheta = bent ? k : 0.0f, dBeyond = bent ? 0.0f : 1.0f;
      w.m[a][a] = -c * dTheta * (z - invK) - s * dTheta * beyond + c * dBeyond;
      w.m[b][a] = -s * dTheta * (z - invK) + c * dTheta * beyond + s * dBeyond;
      w.m[a][b] = -s;
      w.m[b][b] = c;
      break;
    }
    default:
      break;
  }
  jacobian = times(w, jacobian);
  return p;
}

FieldGradient evaluateGradient(const Program& program, const vec3& p) { return run<false>(program, p); }

FieldGradient evaluateGradientColour(const Program& program, const vec3& p) { return run<true>(program, p); }

vec3 outwardNormal(const vec3& g) {
  const float len = glm::length(g);
  return len > 0.0f ? -g / len : vec3(0.0f, 0.0f, 1.0f);
}

vec3 analyticNormal(const Program& program, const vec3& p) { return outwardNormal(evaluateGradient(program, p).gradient); }

}  // namespace blobvk::blobtree
