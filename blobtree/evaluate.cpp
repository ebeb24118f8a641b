// Scalar reference evaluator. The GLSL evaluator (shaders/eval_program.glsl) mirrors this file
// operation for operation; keep them in step.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/pow_field.h"
#include "blobvk/blobtree/triangle_closest.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <type_traits>

namespace blobvk::blobtree {
namespace {

using layout::uint;

template <typename T>
using V3 = glm::vec<3, T>;

template <typename T = float>
V3<T> xyz(const layout::vec4& v) { return {T(v.x), T(v.y), T(v.z)}; }

template <typename T>
V3<T> toLocal(const layout::MatrixRecord& m, const V3<T>& p) {
  return {T(m.r0.x) * p.x + T(m.r0.y) * p.y + T(m.r0.z) * p.z + T(m.r0.w),
          T(m.r1.x) * p.x + T(m.r1.y) * p.y + T(m.r1.z) * p.z + T(m.r1.w),
          T(m.r2.x) * p.x + T(m.r2.y) * p.y + T(m.r2.z) * p.z + T(m.r2.w)};
}

template <typename T>
T triangleDistance2(V3<T> p, V3<T> a, V3<T> b, V3<T> c) {
  const V3<T> d = p - detail::triangleClosest<T>(p, a, b, c);
  return glm::dot(d, d);
}

template <typename T>
bool outside(const layout::BoxRecord& box, const V3<T>& p) {
  return p.x < box.lo.x || p.y < box.lo.y || p.z < box.lo.z || p.x > box.hi.x || p.y > box.hi.y ||
         p.z > box.hi.z;
}

// The per-primitive formula in arithmetic T (float: the reference; double: the precise oracle).
template <typename T>
T primitiveFieldT(const Program& program, const layout::PrimitiveRecord& prim, V3<T> p) {
  if (prim.meta.y != 0u) p = toLocal(program.matrices[prim.meta.y], p);
  const V3<T> p0 = xyz<T>(prim.p0), p1 = xyz<T>(prim.p1);
  const T zero(0), one(1);
  T dd = zero;
  switch (prim.meta.x) {
    case layout::PRIM_POINT: {
      const V3<T> d = p - p0;
      dd = glm::dot(d, d);
      break;
    }
    case layout::PRIM_LINE: {
      const V3<T> d = p - p0;
      const T t = std::clamp(glm::dot(d, p1) * T(prim.p1.w), zero, one);
      const V3<T> e = d - p1 * t;
      dd = glm::dot(e, e);
      break;
    }
    case layout::PRIM_CYLINDER: {
      const V3<T> d = p - p0;
      const T y = glm::dot(d, p1);
      const T r2 = std::max(glm::dot(d, d) - y * y, zero);
      const T x = std::max(std::sqrt(r2) - T(prim.p2.x), zero);
      const T h = std::max(std::max(-y, y - T(prim.p2.y)), zero);
      dd = x * x + h * h;
      break;
    }
    case layout::PRIM_DISC: {
      const V3<T> d = p - p0;
      const T y = glm::dot(d, p1);
      const T r2 = std::max(glm::dot(d, d) - y * y, zero);
      const T radial = std::max(std::sqrt(r2) - T(prim.p2.x), zero);
      dd = radial * radial + y * y;
      break;
    }
    case layout::PRIM_RING: {
      const V3<T> d = p - p0;
      const T y = glm::dot(d, p1);
      const T r2 = std::max(glm::dot(d, d) - y * y, zero);
      const T radial = std::sqrt(r2) - T(prim.p2.x);
      dd = radial * radial + y * y;
      break;
    }
    case layout::PRIM_CUBE: {
      const V3<T> e = glm::max(glm::abs(p - p0) - p1, V3<T>(zero));
      dd = glm::dot(e, e);
      break;
    }
    case layout::PRIM_TRIANGLE:
      dd = triangleDistance2<T>(p, p0, p1, xyz<T>(prim.p2));
      break;
    case layout::PRIM_QUADRIC: {
      const V3<T> d = p - p0;
      dd = glm::dot(d, d);
      const T t = one - dd;
      return dd < one ? T(prim.p0.w) * t * t : zero;
    }
    default:
      return zero;
  }
  const T t = one - dd;
  return dd < one ? t * t * t : zero;
}

template <typename T>
V3<T> applyWarpT(const Program& program, const layout::WarpRecord& warp, V3<T> p) {
  if (warp.meta.w != 0u) p = toLocal(program.matrices[warp.meta.w], p);
  const uint a = warp.meta.y, b = warp.meta.z;
  const T k = T(warp.params.x);
  switch (warp.meta.x) {
    case layout::WARP_TWIST: {
      // Rotate the plane (u, v) normal to axis a, u and v in cyclic order after a.
      const uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
      const T theta = k * p[a];
      const T c = std::cos(theta), s = std::sin(theta);
      const T pu = p[u], pv = p[v];
      p[u] = pu * c - pv * s;
      p[v] = pu * s + pv * c;
      break;
    }
    case layout::WARP_TAPER:
      p[b] = p[b] * (T(1) + k * p[a]);
      break;
    case layout::WARP_SHEAR:
      p[a] = p[a] + k * p[b];
      break;
    case layout::WARP_BEND: {
      if (k == T(0)) break;
      const T y = p[a], z = p[b];
      const T yc = std::clamp(y, T(warp.params.z), T(warp.params.w));
      const T theta = k * (yc - T(warp.params.y));
      const T c = std::cos(theta), s = std::sin(theta);
      const T invK = T(1) / k;
      const T beyond = y - yc;  // distance past the bent region, continued straight
      p[a] = -s * (z - invK) + T(warp.params.y) + c * beyond;
      p[b] = c * (z - invK) + invK + s * beyond;
      break;
    }
    default:
      break;
  }
  return p;
}

template <typename T>
struct Result {
  T field = T(0);
  glm::vec3 colour{0.0f};
};

// One pass over the code. Colour is a template switch so the field-only path carries no colour
// work (the same split the shaders and AVX evaluators make).
template <typename T, bool kColour>
Result<T> run(const Program& program, const V3<T>& p) {
  std::array<T, layout::MAX_FIELD_REGISTERS> reg{};
  std::array<glm::vec3, layout::MAX_FIELD_REGISTERS> col{};
  std::array<V3<T>, layout::MAX_POINT_REGISTERS> pts{};
  const T zero(0), one(1);
  pts[0] = p;
  const std::size_t n = program.code.size();
  for (std::size_t pc = 0; pc < n; ++pc) {
    const layout::uvec4 in = program.code[pc].code;
    const uint op = in.x & 0xffu;
    const uint dst = in.x >> 8;
    switch (op) {
      case layout::OP_PRIM: {
        const auto& prim = program.primitives[in.y];
        reg[dst] = primitiveFieldT<T>(program, prim, pts[in.z]);
        if constexpr (kColour) col[dst] = unpackColour(prim.meta.z);
        break;
      }
      case layout::OP_ADD: {
        const T a = reg[dst], b = reg[in.y];
        if constexpr (kColour) {
          const float wa = std::max(float(a), 0.0f), wb = std::max(float(b), 0.0f);
          const float w = wa + wb;
          if (w > 0.0f) col[dst] = (col[dst] * wa + col[in.y] * wb) / w;
        }
        reg[dst] = a + b;
        break;
      }
      case layout::OP_MAX:
        if constexpr (kColour) {
          if (reg[in.y] > reg[dst]) col[dst] = col[in.y];
        }
        reg[dst] = std::max(reg[dst], reg[in.y]);
        break;
      case layout::OP_MIN:
        if constexpr (kColour) {
          if (reg[in.y] < reg[dst]) col[dst] = col[in.y];
        }
        reg[dst] = std::min(reg[dst], reg[in.y]);
        break;
      case layout::OP_DIFF: {
        const T cut = one - reg[in.y];
        if constexpr (kColour) {
          if (cut < reg[dst]) col[dst] = col[in.y];
        }
        reg[dst] = std::min(reg[dst], cut);
        break;
      }
      case layout::OP_SDIFF: {
        const T keep = one - reg[in.y];
        if constexpr (kColour) {
          if (keep < reg[dst]) col[dst] = col[in.y];
        }
        reg[dst] = reg[dst] * keep;
        break;
      }
      case layout::OP_ONE_MINUS:
        reg[dst] = one - reg[dst];
        break;
      case layout::OP_MUL:
        if constexpr (kColour) {
          if (reg[in.y] < reg[dst]) col[dst] = col[in.y];
        }
        reg[dst] = reg[dst] * reg[in.y];
        break;
      case layout::OP_POW:
        if constexpr (std::is_same_v<T, float>) {
          reg[dst] = powField(reg[dst], std::bit_cast<float>(in.w));
        } else {  // the precise oracle: exact arithmetic, no flush
          reg[dst] = std::pow(std::max(reg[dst], zero), T(std::bit_cast<float>(in.w)));
        }
        break;
      case layout::OP_WARP:
        pts[dst] = applyWarpT<T>(program, program.warps[in.y], pts[in.z]);
        break;
      case layout::OP_SKIP:
        if (outside(program.boxes[in.y], pts[in.z])) {
          reg[dst] = zero;
          if constexpr (kColour) col[dst] = glm::vec3(0.0f);
          pc = std::size_t(in.w) - 1;  // the loop's ++pc lands on the target
        }
        break;
      default:
        break;  // compile() emits no other opcode
    }
  }
  return {n ? reg[0] : zero, col[0]};
}

}  // namespace

glm::vec3 unpackColour(std::uint32_t rgba) {
  return {float(rgba & 0xffu) / 255.0f, float((rgba >> 8) & 0xffu) / 255.0f,
          float((rgba >> 16) & 0xffu) / 255.0f};
}

float primitiveField(const Program& program, const layout::PrimitiveRecord& prim, glm::vec3 p) {
  return primitiveFieldT<float>(program, prim, p);
}

glm::vec3 applyWarp(const Program& program, const layout::WarpRecord& warp, glm::vec3 p) {
  return applyWarpT<float>(program, warp, p);
}

float evaluate(const Program& program, const glm::vec3& p) {
  return run<float, false>(program, p).field;
}

double evaluatePrecise(const Program& program, const glm::dvec3& p) {
  return run<double, false>(program, p).field;
}

FieldColour evaluateWithColour(const Program& program, const glm::vec3& p) {
  const Result<float> r = run<float, true>(program, p);
  return {r.field, r.colour};
}

glm::vec3 gradient(const Program& program, const glm::vec3& p, float h) {
  const float inv = 0.5f / h;
  return {(evaluate(program, p + glm::vec3(h, 0, 0)) - evaluate(program, p - glm::vec3(h, 0, 0))) * inv,
          (evaluate(program, p + glm::vec3(0, h, 0)) - evaluate(program, p - glm::vec3(0, h, 0))) * inv,
          (evaluate(program, p + glm::vec3(0, 0, h)) - evaluate(program, p - glm::vec3(0, 0, h))) * inv};
}

glm::vec3 normal(const Program& program, const glm::vec3& p, float h) {
  const glm::vec3 g = gradient(program, p, h);
  const float len = glm::length(g);
  return len > 0.0f ? -g / len : glm::vec3(0.0f, 0.0f, 1.0f);
}

}  // namespace blobvk::blobtree
