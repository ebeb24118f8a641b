// The field, warp and box formulas of blobtree/evaluate.cpp as pure functions of their record
// values, shared by the interpreting evaluator (eval_program.glsl, which loads the values from the
// Program's buffers) and the specialised one (vk/eval/program_codegen.cpp, which passes literals).
// One copy of each formula means both evaluators compute the same float operations in the same
// order as the C++ reference; keep them in step with evaluate.cpp.
//
// Every formula is `precise` (glslang propagates the qualifier from a function's return value to
// every operation it depends on, locals included: SPIR-V NoContraction), so no driver may fuse
// a * b + c into an fma: the C++ side is built with -ffp-contract=off, and a fused result rounds
// differently. Dot products are written out (dot3) in the reference's order, x, y, then z: the
// precision of OpDot is the driver's choice. docs/vulkan.md says what agreement this buys.
#ifndef BLOBVK_EVAL_FORMULAS_GLSL
#define BLOBVK_EVAL_FORMULAS_GLSL

precise float dot3(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

precise vec3 toLocalRows(vec4 r0, vec4 r1, vec4 r2, vec3 p) {
  return vec3(r0.x * p.x + r0.y * p.y + r0.z * p.z + r0.w,
              r1.x * p.x + r1.y * p.y + r1.z * p.z + r1.w,
              r2.x * p.x + r2.y * p.y + r2.z * p.z + r2.w);
}

precise float wyvill(float dd) {
  float t = 1.0 - dd;
  return dd < 1.0 ? t * t * t : 0.0;
}

// Squared distances to the skeletons (record meanings in program_layout.h).
precise float ddPoint(vec3 p, vec3 p0) {
  vec3 d = p - p0;
  return dot3(d, d);
}

precise float ddLine(vec3 p, vec3 p0, vec4 p1) {
  vec3 d = p - p0;
  float t = clamp(dot3(d, p1.xyz) * p1.w, 0.0, 1.0);
  vec3 e = d - p1.xyz * t;
  return dot3(e, e);
}

precise float ddCylinder(vec3 p, vec3 p0, vec3 axis, float radius, float height) {
  vec3 d = p - p0;
  float y = dot3(d, axis);
  float r2 = max(dot3(d, d) - y * y, 0.0);
  float x = max(sqrt(r2) - radius, 0.0);
  float h = max(max(-y, y - height), 0.0);
  return x * x + h * h;
}

precise float ddDisc(vec3 p, vec3 p0, vec3 normal, float radius) {
  vec3 d = p - p0;
  float y = dot3(d, normal);
  float r2 = max(dot3(d, d) - y * y, 0.0);
  float radial = max(sqrt(r2) - radius, 0.0);
  return radial * radial + y * y;
}

precise float ddRing(vec3 p, vec3 p0, vec3 normal, float radius) {
  vec3 d = p - p0;
  float y = dot3(d, normal);
  float r2 = max(dot3(d, d) - y * y, 0.0);
  float radial = sqrt(r2) - radius;
  return radial * radial + y * y;
}

precise float ddCube(vec3 p, vec3 p0, vec3 halfExtents) {
  vec3 e = max(abs(p - p0) - halfExtents, vec3(0.0));
  return dot3(e, e);
}

// Ericson, Real-Time Collision Detection 5.1.5, as in blobtree/triangle_closest.h.
precise vec3 triangleClosest(vec3 p, vec3 a, vec3 b, vec3 c) {
  vec3 ab = b - a, ac = c - a, ap = p - a;
  float d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  vec3 closest;
  if (d1 <= 0.0 && d2 <= 0.0) {
    closest = a;
  } else {
    vec3 bp = p - b;
    float d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    vec3 cp = p - c;
    float d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    float vc = d1 * d4 - d3 * d2;
    float vb = d5 * d2 - d1 * d6;
    float va = d3 * d6 - d5 * d4;
    precise float d43 = d4 - d3, d56 = d5 - d6;  // precise: also read by a comparison
    if (d3 >= 0.0 && d4 <= d3) {
      closest = b;
    } else if (d6 >= 0.0 && d5 <= d6) {
      closest = c;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      closest = a + ab * (d1 / (d1 - d3));
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      closest = a + ac * (d2 / (d2 - d6));
    } else if (va <= 0.0 && d43 >= 0.0 && d56 >= 0.0) {
      closest = b + (c - b) * (d43 / (d43 + d56));
    } else {
      float sum = va + vb + vc;
      float denom = sum != 0.0 ? 1.0 / sum : 0.0;
      closest = a + ab * (vb * denom) + ac * (vc * denom);
    }
  }
  return closest;
}

precise float triangleDistance2(vec3 p, vec3 a, vec3 b, vec3 c) {
  vec3 d = p - triangleClosest(p, a, b, c);
  return dot3(d, d);
}

// The quadric point's whole field (not a squared distance): S (1 - dd)^2 inside the unit ball.
precise float quadricField(vec3 p, vec3 p0, float scale) {
  vec3 d = p - p0;
  float q = dot3(d, d);
  float t = 1.0 - q;
  return q < 1.0 ? scale * t * t : 0.0;
}

// Warps (axes a, b in 0..2; params as in WarpRecord).
precise vec3 warpTwist(vec3 p, uint a, float k) {
  uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
  float theta = k * p[a];
  float c = cos(theta), s = sin(theta);
  float pu = p[u], pv = p[v];
  p[u] = pu * c - pv * s;
  p[v] = pu * s + pv * c;
  return p;
}

precise vec3 warpTaper(vec3 p, uint a, uint b, float k) {
  p[b] = p[b] * (1.0 + k * p[a]);
  return p;
}

precise vec3 warpShear(vec3 p, uint a, uint b, float k) {
  p[a] = p[a] + k * p[b];
  return p;
}

precise vec3 warpBend(vec3 p, uint a, uint b, vec4 params) {
  float k = params.x;
  if (k == 0.0) return p;
  float y = p[a], z = p[b];
  float yc = clamp(y, params.z, params.w);
  float theta = k * (yc - params.y);
  float c = cos(theta), s = sin(theta);
  float invK = 1.0 / k;
  float beyond = y - yc;
  p[a] = -s * (z - invK) + params.y + c * beyond;
  p[b] = c * (z - invK) + invK + s * beyond;
  return p;
}

precise vec3 unpackColour(uint rgba) {
  return vec3(float(rgba & 0xffu) / 255.0, float((rgba >> 8) & 0xffu) / 255.0,
              float((rgba >> 16) & 0xffu) / 255.0);
}

bool outsideBoxBounds(vec3 lo, vec3 hi, vec3 p) {
  return p.x < lo.x || p.y < lo.y || p.z < lo.z || p.x > hi.x || p.y > hi.y || p.z > hi.z;
}

// OP_POW (blobtree/pow_field.h): pow(max(base, 0), e) for e > 0, with pow(0, e) = 0 (GLSL leaves it
// undefined; std::pow gives 0), and a result below the smallest normal float +0 on every device,
// whether it flushes denormals (llvmpipe does) or not, as the CPU evaluators do. Callers pass e
// from the code buffer, not as a literal: NIR would rewrite pow(x, 4.0) as x*x*x*x.
float powField(float base, float e) {
  float r = base > 0.0 ? pow(base, e) : 0.0;
  return r < 1.17549435e-38 ? 0.0 : r;
}

#endif  // BLOBVK_EVAL_FORMULAS_GLSL
