// The sparse extraction's brick classification (brick_classify.comp, brick_classify_uniform.comp):
// everything but the Program's record bindings (0-4), which the including kernel declares as
// storage buffers (any size) or uniform buffers (llvmpipe loads a uniform buffer at a per-lane
// index with one vector gather, a storage buffer with a loop over the lanes).
#ifndef BLOBVK_BRICK_CLASSIFY_BODY_GLSL
#define BLOBVK_BRICK_CLASSIFY_BODY_GLSL
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

#include "program_masks.glsl"

layout(std430, set = 0, binding = 5) writeonly buffer ActiveFlags { uint activeFlags[]; };
// With pc.parents.w = 1: the flags of a first pass over bricks of twice the size (2 x 2 x 2 of
// these each). A brick inside a dropped parent is dropped without its own bound: the parent's box
// holds its box, so its samples are on the parent's one side. On llvmpipe a vector of lanes whose
// parents are all dropped leaves the interval loop after one pass; where most of the grid is
// dropped (random128: 80 % of its bricks of 8 cells lie in dropped bricks of 16), the two passes
// cost less than one.
layout(std430, set = 0, binding = 6) readonly buffer ParentFlags { uint parentFlags[]; };

layout(push_constant) uniform Push {
  vec4 originCell;          // grid origin, cell size
  uvec4 cells;              // cells per axis, w = log2(B)
  uvec4 bricks;             // bricks per axis, w = code length
  uvec4 parents;            // parent bricks per axis, w = 1: use parentFlags
  // The bricks classified: [first, end) per axis (the whole grid, a window of brick layers, or an
  // edit's box of bricks, vk/extract/incremental_extract.cpp); the host leaves the others' flags
  // at 0. first.w: the brick (linear index) whose flag is activeFlags[0]; end.w: the flags' last
  // word (0, so that an exclusive scan ends with the active count), written by brick first.w.
  uvec4 first, end;
  uint parentBase;          // the parent brick (linear index) whose flag is parentFlags[0]
} pc;

const float INF = 1.0 / 0.0;  // +infinity

struct Box {
  vec3 lo, hi;
};

bool finiteBox(Box b) { return all(lessThan(abs(b.lo), vec3(1e30))) && all(lessThan(abs(b.hi), vec3(1e30))); }
Box everything() { return Box(vec3(-INF), vec3(INF)); }

// Float evaluation of coordinates errs by a few ulps of the largest magnitude: pad by more.
Box padBox(Box b) {
  if (!finiteBox(b)) return everything();
  vec3 m = max(max(abs(b.lo), abs(b.hi)), vec3(1.0)) * 1e-5;
  return Box(b.lo - m, b.hi + m);
}

Box transformBox(MatrixRecord m, Box b) {
  if (!finiteBox(b)) return everything();
  vec4 rows[3] = vec4[3](vec4(m.r0.x, m.r0.y, m.r0.z, m.r0.w), vec4(m.r1.x, m.r1.y, m.r1.z, m.r1.w),
                         vec4(m.r2.x, m.r2.y, m.r2.z, m.r2.w));
  Box o;
  for (int r = 0; r < 3; ++r) {
    vec3 u = rows[r].xyz * b.lo, v = rows[r].xyz * b.hi;
    vec3 lo = min(u, v), hi = max(u, v);
    float magnitude = abs(rows[r].w) + dot(max(abs(u), abs(v)), vec3(1.0));
    // The reference's float sum of products errs by a few ulps of its largest terms.
    float rounding = 1e-5 * magnitude;
    o.lo[r] = rows[r].w + lo.x + lo.y + lo.z - rounding;
    o.hi[r] = rows[r].w + hi.x + hi.y + hi.z + rounding;
  }
  return padBox(o);
}

vec2 mulInterval(vec2 a, vec2 b) {
  vec4 p = vec4(a.x * b.x, a.x * b.y, a.y * b.x, a.y * b.y);
  vec2 r = vec2(min(min(p.x, p.y), min(p.z, p.w)), max(max(p.x, p.y), max(p.z, p.w)));
  if (any(isnan(r))) r = vec2(-INF, INF);
  return r;
}

// The operators on intervals, shared by the interpreter and generated code (one formula each).
vec2 diffInterval(vec2 d, vec2 y) { return vec2(min(d.x, 1.0 - y.y), min(d.y, 1.0 - y.x)); }
vec2 sdiffInterval(vec2 d, vec2 y) { return mulInterval(d, vec2(1.0 - y.y, 1.0 - y.x)); }
vec2 oneMinusInterval(vec2 d) { return vec2(1.0 - d.y, 1.0 - d.x); }
vec2 powInterval(vec2 d, float e) {
  if (!(e > 0.0)) return vec2(0.0, INF);
  // pow's precision is the driver's: widen by a relative margin. Ends below the smallest normal
  // float are +0, as the evaluators' powField flushes its results (eval_formulas.glsl).
  float lo = d.x > 0.0 ? pow(d.x, e) * (1.0 - 1e-4) : 0.0, hi = d.y > 0.0 ? pow(d.y, e) * (1.0 + 1e-4) : 0.0;
  return vec2(lo < 1.17549435e-38 ? 0.0 : lo, hi < 1.17549435e-38 ? 0.0 : hi);
}

// A skip's box against the query box: missed (the subtree is 0 there) or held whole (no widening).
bool skipMisses(BoxRecord s, Box q) {
  return any(lessThan(q.hi, vec3(s.lo.x, s.lo.y, s.lo.z))) || any(greaterThan(q.lo, vec3(s.hi.x, s.hi.y, s.hi.z)));
}
bool skipHolds(BoxRecord s, Box q) {
  return all(greaterThanEqual(q.lo, vec3(s.lo.x, s.lo.y, s.lo.z))) && all(lessThanEqual(q.hi, vec3(s.hi.x, s.hi.y, s.hi.z)));
}

// Smallest and largest squared distance between the box and the skeleton box [slo, shi].
vec2 boxDistance2(Box a, vec3 slo, vec3 shi) {
  vec3 gap = max(max(slo - a.hi, a.lo - shi), vec3(0.0));
  vec3 far = max(abs(shi - a.lo), abs(a.hi - slo));
  return vec2(dot(gap, gap), dot(far, far));
}

// Box of the skeleton in the unit frame (cpu_simd/field_bounds.cpp skeletonBox).
void skeletonBox(uint index, uint type, out vec3 lo, out vec3 hi) {
  vec3 c = programPrims[index].p0.xyz, n = programPrims[index].p1.xyz;
  vec3 inPlane = sqrt(max(vec3(0.0), vec3(1.0) - n * n));
  if (HAS_PRIM(PRIM_LINE) && type == PRIM_LINE) {
    lo = min(c, c + n);
    hi = max(c, c + n);
  } else if (HAS_PRIM(PRIM_CYLINDER) && type == PRIM_CYLINDER) {
    vec3 top = c + n * programPrims[index].p2.y;
    vec3 ext = inPlane * abs(programPrims[index].p2.x);
    lo = min(c, top) - ext;
    hi = max(c, top) + ext;
  } else if ((HAS_PRIM(PRIM_DISC) && type == PRIM_DISC) || (HAS_PRIM(PRIM_RING) && type == PRIM_RING)) {
    vec3 ext = inPlane * abs(programPrims[index].p2.x);
    lo = c - ext;
    hi = c + ext;
  } else if (HAS_PRIM(PRIM_CUBE) && type == PRIM_CUBE) {
    lo = c - abs(n);
    hi = c + abs(n);
  } else if (HAS_PRIM(PRIM_TRIANGLE) && type == PRIM_TRIANGLE) {
    vec3 q = programPrims[index].p2.xyz;
    lo = min(min(c, n), q);
    hi = max(max(c, n), q);
  } else {  // point, quadric
    lo = c;
    hi = c;
  }
  // Unit-normal rounding and float distance arithmetic: an absolute pad in the unit frame.
  lo -= vec3(1e-4);
  hi += vec3(1e-4);
}

// Primitive `index` of `type` (its meta.x) with matrix `matrix` (its meta.y, 0: none): the type and
// matrix as arguments so that generated code, passing them as literals, keeps only its type's code.
vec2 primitiveBounds(uint index, uint type, uint matrix, Box world) {
  if (type > PRIM_QUADRIC) return vec2(0.0);  // the reference gives 0 for unknown types
  Box local = (PRIM_MASK & MASK_HAS_MATRIX) != 0u && matrix != 0u ? transformBox(programMatrices[matrix], world) : world;
  float scale = type == PRIM_QUADRIC ? programPrims[index].p0.w : 1.0;
  if (!finiteBox(local)) return vec2(min(0.0, scale), max(0.0, scale));
  vec3 slo, shi;
  skeletonBox(index, type, slo, shi);
  vec2 dd = boxDistance2(local, slo, shi);
  // Relative rounding of the distances (the reference's and this one's).
  dd = vec2(dd.x * (1.0 - 1e-5), dd.y * (1.0 + 1e-5));
  if (dd.x >= 1.0) return vec2(0.0);
  float tHi = 1.0 - dd.x, tLo = max(1.0 - dd.y, 0.0);
  if (type == PRIM_QUADRIC) return vec2(min(0.0, scale), max(0.0, scale * tHi * tHi));
  return vec2(tLo * tLo * tLo, tHi * tHi * tHi);
}

// The box of the rectangle [lo, hi] turned (as a twist and a bend turn: (x c - y s, x s + y c))
// by every angle in [t0, t1]: the rectangle turned by the middle angle (its corners' box), grown
// by how far the rest of the turn moves a point (r times half the span: a chord is shorter than
// its arc) and by 4e-3 r for sin and cos, this bound's and the evaluation's (Vulkan allows each
// 2^-11 within [-pi, pi], which moves a turned point by under 7e-4 r), within the disc of the
// farthest corner's radius r; that disc alone where an angle lies outside [-pi, pi] (no precision
// is promised there: false). (The CPU's bound, cpu_simd/field_bounds.cpp, takes the turned
// annular sector with libm's sin and cos.)
bool turnedRectangle(vec2 lo, vec2 hi, float t0, float t1, out vec2 outLo, out vec2 outHi) {
  float r = length(max(abs(lo), abs(hi)));
  float reach = r * (1.0 + 4e-3);
  outLo = vec2(-reach);
  outHi = vec2(reach);
  float middle = 0.5 * (t0 + t1), halfSpan = 0.5 * abs(t1 - t0);
  if (!(max(abs(t0), abs(t1)) <= 3.14159)) return false;
  float c = cos(middle), s = sin(middle);
  vec2 p0 = vec2(lo.x * c - lo.y * s, lo.x * s + lo.y * c), p1 = vec2(hi.x * c - lo.y * s, hi.x * s + lo.y * c);
  vec2 p2 = vec2(lo.x * c - hi.y * s, lo.x * s + hi.y * c), p3 = vec2(hi.x * c - hi.y * s, hi.x * s + hi.y * c);
  float m = r * (halfSpan + 4e-3);
  outLo = max(min(min(p0, p1), min(p2, p3)) - vec2(m), outLo);
  outHi = min(max(max(p0, p1), max(p2, p3)) + vec2(m), outHi);
  return true;
}

// Warp `index` whose record's meta word is `meta` (an argument, as primitiveBounds' type).
Box warpBox(uint index, uvec4 meta, Box b) {
  if ((WARP_MASK & MASK_HAS_MATRIX) != 0u && meta.w != 0u) b = transformBox(programMatrices[meta.w], b);
  if (!finiteBox(b)) return b;
  uint a = min(meta.y, 2u), c = min(meta.z, 2u);
  float k = programWarps[index].params.x;
  if (HAS_WARP(WARP_TWIST) && meta.x == WARP_TWIST) {
    // A rotation about axis a by k p[a]: the coordinate along a stays, the cross-section turns.
    uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    vec2 lo, hi;  // (the disc past half a turn, as before)
    turnedRectangle(vec2(b.lo[u], b.lo[v]), vec2(b.hi[u], b.hi[v]), min(k * b.lo[a], k * b.hi[a]),
                    max(k * b.lo[a], k * b.hi[a]), lo, hi);
    b.lo[u] = lo.x;
    b.lo[v] = lo.y;
    b.hi[u] = hi.x;
    b.hi[v] = hi.y;
    return padBox(b);
  }
  if (HAS_WARP(WARP_BEND) && meta.x == WARP_BEND) {
    // p maps to (c0, 1/k) + the turn by k (clamp(p[a], lo, hi) - c0) of (how far p lies past the
    // bent region along a, p[c] - 1/k) (blobtree/evaluate.cpp); the angle and the rectangle bounded apart.
    if (k == 0.0) return padBox(b);
    vec4 w = programWarps[index].params;
    // The evaluation's 1/k (eval_formulas.glsl) may differ from this one by a few ulps (Vulkan:
    // 2.5 each), which moves the point by as much times |1/k|: kept on both axes.
    float invK = 1.0 / k;
    if (isinf(invK) || isnan(invK)) return everything();
    float divisionMargin = 2e-6 * abs(invK);
    float y0 = clamp(b.lo[a], w.z, w.w), y1 = clamp(b.hi[a], w.z, w.w);
    vec2 lo, hi;
    // Past half a turn either way the device's sin and cos promise nothing: no bound, as before.
    if (!turnedRectangle(vec2(b.lo[a] - y0, b.lo[c] - invK), vec2(b.hi[a] - y1, b.hi[c] - invK),
                         min(k * (y0 - w.y), k * (y1 - w.y)), max(k * (y0 - w.y), k * (y1 - w.y)), lo, hi))
      return everything();
    b.lo[a] = lo.x + w.y - divisionMargin;
    b.hi[a] = hi.x + w.y + divisionMargin;
    b.lo[c] = lo.y + invK - divisionMargin;
    b.hi[c] = hi.y + invK + divisionMargin;
    return padBox(b);
  }
  if (HAS_WARP(WARP_TAPER) && meta.x == WARP_TAPER) {
    vec2 f = mulInterval(vec2(b.lo[c], b.hi[c]), vec2(1.0 + min(k * b.lo[a], k * b.hi[a]), 1.0 + max(k * b.lo[a], k * b.hi[a])));
    b.lo[c] = f.x;
    b.hi[c] = f.y;
    return padBox(b);
  }
  if (HAS_WARP(WARP_SHEAR) && meta.x == WARP_SHEAR) {
    vec2 s = mulInterval(vec2(b.lo[c], b.hi[c]), vec2(k));
    b.lo[a] += s.x;
    b.hi[a] += s.y;
    return padBox(b);
  }
  return everything();  // unknown
}

// fieldBounds(Box query, out bool gaveUp): the interval of the field over `query`. Embedded: the
// interpreter of the register code (brick_classify_bounds.glsl); a generated kernel replaces that
// file with the Program spelled out (vk/eval/interval_codegen.h), the same helpers called with
// the same records, so both give the same bound bit for bit.
#include "brick_classify_bounds.glsl"

void main() {
  uvec3 b = gl_GlobalInvocationID + pc.first.xyz;
  if (any(greaterThanEqual(b, pc.end.xyz))) return;
  uint brick = (b.z * pc.bricks.y + b.y) * pc.bricks.x + b.x - pc.first.w;
  if (brick == 0u) activeFlags[pc.end.w] = 0u;
  if (pc.parents.w != 0u) {
    uvec3 q = b >> 1u;
    if (parentFlags[(q.z * pc.parents.y + q.y) * pc.parents.x + q.x - pc.parentBase] == 0u) {
      activeFlags[brick] = 0u;
      return;
    }
  }
  uint B = 1u << pc.cells.w;
  uvec3 first = b * B, last = min(first + B, pc.cells.xyz);
  Box box = Box(pc.originCell.xyz + pc.originCell.w * vec3(first), pc.originCell.xyz + pc.originCell.w * vec3(last));
  bool gaveUp;
  vec2 f = fieldBounds(box, gaveUp);
  // The reference's float rounding of sums and products, and this bound's own float rounding.
  float margin = 1e-3 * max(1.0, max(abs(f.x), abs(f.y)));
  bool uniformSide = !gaveUp && (f.y < ISO_VALUE - margin || f.x >= ISO_VALUE + margin);
  activeFlags[brick] = uniformSide ? 0u : 1u;
}

#endif
