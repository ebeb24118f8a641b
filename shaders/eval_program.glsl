// The stackless register-machine evaluator of a compiled Program: GLSL twin of
// blobtree/evaluate.cpp (same float operations in the same order; keep them in step).
//
// The includer defines PROGRAM_SET (descriptor set, usually 0) and PROGRAM_BINDING (first of five
// consecutive bindings: code, primitives, matrices, boxes, warps), then includes this file before
// any other code (it enables GL_KHR_shader_subgroup_vote).
//
// Specialization constants (vk::GpuProgram::specs() fills them from the Program; the defaults are
// correct for every program, only slower):
//   0 workgroup size (common.glsl), 1 traversal,
//   2 FIELD_REGS   registers the code uses (Program::fieldRegisters; default 32 = the layout's max)
//   3 OP_MASK      bit op set when the code contains opcode op (default all)
//   4 PRIM_MASK    bit t set when a primitive of type t exists; bit 31: some primitive has a matrix
//   5 WARP_MASK    bit t set when a warp of type t exists; bit 31: some warp has a matrix
// They let the compiler drop every case a program cannot reach. That matters most on llvmpipe
// (lavapipe), which runs both sides of every branch under an execution mask: an unused
// triangle-distance, sin/cos or pow would otherwise be paid on every instruction.
#ifndef BLOBVK_EVAL_PROGRAM_GLSL
#define BLOBVK_EVAL_PROGRAM_GLSL

#extension GL_KHR_shader_subgroup_vote : require

#include "program_layout.h"

layout(constant_id = 1) const uint TRAVERSAL = 0u;  // 0 stackless, 1 stack-based
layout(constant_id = 2) const uint FIELD_REGS = 32u;
layout(constant_id = 3) const uint OP_MASK = 0xffffffffu;
layout(constant_id = 4) const uint PRIM_MASK = 0xffffffffu;
layout(constant_id = 5) const uint WARP_MASK = 0xffffffffu;
#define HAS_OP(op) ((OP_MASK & (1u << (op))) != 0u)
#define HAS_PRIM(t) ((PRIM_MASK & (1u << (t))) != 0u)
#define HAS_WARP(t) ((WARP_MASK & (1u << (t))) != 0u)
const uint MASK_HAS_MATRIX = 0x80000000u;

#include "eval_registers.glsl"

layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 0) readonly buffer ProgramCode {
  Instruction programCode[];
};
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 1) readonly buffer ProgramPrims {
  PrimitiveRecord programPrims[];
};
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 2) readonly buffer ProgramMatrices {
  MatrixRecord programMatrices[];
};
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 3) readonly buffer ProgramBoxes {
  BoxRecord programBoxes[];
};
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 4) readonly buffer ProgramWarps {
  WarpRecord programWarps[];
};

vec3 toLocal(MatrixRecord m, vec3 p) {
  return vec3(m.r0.x * p.x + m.r0.y * p.y + m.r0.z * p.z + m.r0.w,
              m.r1.x * p.x + m.r1.y * p.y + m.r1.z * p.z + m.r1.w,
              m.r2.x * p.x + m.r2.y * p.y + m.r2.z * p.z + m.r2.w);
}

float wyvill(float dd) {
  float t = 1.0 - dd;
  return dd < 1.0 ? t * t * t : 0.0;
}

// Ericson, Real-Time Collision Detection 5.1.5, as in evaluate.cpp.
float triangleDistance2(vec3 p, vec3 a, vec3 b, vec3 c) {
  vec3 ab = b - a, ac = c - a, ap = p - a;
  float d1 = dot(ab, ap), d2 = dot(ac, ap);
  vec3 closest;
  if (d1 <= 0.0 && d2 <= 0.0) {
    closest = a;
  } else {
    vec3 bp = p - b;
    float d3 = dot(ab, bp), d4 = dot(ac, bp);
    vec3 cp = p - c;
    float d5 = dot(ab, cp), d6 = dot(ac, cp);
    float vc = d1 * d4 - d3 * d2;
    float vb = d5 * d2 - d1 * d6;
    float va = d3 * d6 - d5 * d4;
    if (d3 >= 0.0 && d4 <= d3) {
      closest = b;
    } else if (d6 >= 0.0 && d5 <= d6) {
      closest = c;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      closest = a + ab * (d1 / (d1 - d3));
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      closest = a + ac * (d2 / (d2 - d6));
    } else if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
      closest = b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    } else {
      float sum = va + vb + vc;
      float denom = sum != 0.0 ? 1.0 / sum : 0.0;
      closest = a + ab * (vb * denom) + ac * (vc * denom);
    }
  }
  vec3 d = p - closest;
  return dot(d, d);
}

float primitiveField(uint index, vec3 p) {
  // Members are loaded where a type needs them, not the whole 64-byte record: on llvmpipe each
  // storage-buffer component is a load per lane.
  uvec4 meta = programPrims[index].meta;
  if ((PRIM_MASK & MASK_HAS_MATRIX) != 0u && meta.y != 0u)
    p = toLocal(programMatrices[meta.y], p);
  uint type = meta.x;
  vec3 p0 = programPrims[index].p0.xyz;
  float dd = 1.0;  // no field for an unknown type
  // One `if` per type present (not a switch) so that absent types fold away.
  if (HAS_PRIM(PRIM_POINT) && type == PRIM_POINT) {
    vec3 d = p - p0;
    dd = dot(d, d);
  }
  if (HAS_PRIM(PRIM_LINE) && type == PRIM_LINE) {
    vec4 p1 = programPrims[index].p1;
    vec3 d = p - p0;
    float t = clamp(dot(d, p1.xyz) * p1.w, 0.0, 1.0);
    vec3 e = d - p1.xyz * t;
    dd = dot(e, e);
  }
  if (HAS_PRIM(PRIM_CYLINDER) && type == PRIM_CYLINDER) {
    vec4 p1 = programPrims[index].p1;
    vec3 d = p - p0;
    float y = dot(d, p1.xyz);
    float r2 = max(dot(d, d) - y * y, 0.0);
    float x = max(sqrt(r2) - programPrims[index].p2.x, 0.0);
    float h = max(max(-y, y - programPrims[index].p2.y), 0.0);
    dd = x * x + h * h;
  }
  if (HAS_PRIM(PRIM_DISC) && type == PRIM_DISC) {
    vec4 p1 = programPrims[index].p1;
    vec3 d = p - p0;
    float y = dot(d, p1.xyz);
    float r2 = max(dot(d, d) - y * y, 0.0);
    float radial = max(sqrt(r2) - programPrims[index].p2.x, 0.0);
    dd = radial * radial + y * y;
  }
  if (HAS_PRIM(PRIM_RING) && type == PRIM_RING) {
    vec4 p1 = programPrims[index].p1;
    vec3 d = p - p0;
    float y = dot(d, p1.xyz);
    float r2 = max(dot(d, d) - y * y, 0.0);
    float radial = sqrt(r2) - programPrims[index].p2.x;
    dd = radial * radial + y * y;
  }
  if (HAS_PRIM(PRIM_CUBE) && type == PRIM_CUBE) {
    vec4 p1 = programPrims[index].p1;
    vec3 e = max(abs(p - p0) - p1.xyz, vec3(0.0));
    dd = dot(e, e);
  }
  if (HAS_PRIM(PRIM_TRIANGLE) && type == PRIM_TRIANGLE)
    dd = triangleDistance2(p, p0, programPrims[index].p1.xyz, programPrims[index].p2.xyz);
  if (HAS_PRIM(PRIM_QUADRIC) && type == PRIM_QUADRIC) {
    vec3 d = p - p0;
    float q = dot(d, d);
    float t = 1.0 - q;
    return q < 1.0 ? programPrims[index].p0.w * t * t : 0.0;
  }
  return wyvill(dd);
}

vec3 applyWarp(uint index, vec3 p) {
  WarpRecord warp = programWarps[index];
  if ((WARP_MASK & MASK_HAS_MATRIX) != 0u && warp.meta.w != 0u)
    p = toLocal(programMatrices[warp.meta.w], p);
  uint a = warp.meta.y, b = warp.meta.z;
  float k = warp.params.x;
  switch (warp.meta.x) {
    case WARP_TWIST: {
      if (!HAS_WARP(WARP_TWIST)) break;
      uint u = (a + 1u) % 3u, v = (a + 2u) % 3u;
      float theta = k * p[a];
      float c = cos(theta), s = sin(theta);
      float pu = p[u], pv = p[v];
      p[u] = pu * c - pv * s;
      p[v] = pu * s + pv * c;
      break;
    }
    case WARP_TAPER:
      if (HAS_WARP(WARP_TAPER)) p[b] = p[b] * (1.0 + k * p[a]);
      break;
    case WARP_SHEAR:
      if (HAS_WARP(WARP_SHEAR)) p[a] = p[a] + k * p[b];
      break;
    case WARP_BEND: {
      if (!HAS_WARP(WARP_BEND) || k == 0.0) break;
      float y = p[a], z = p[b];
      float yc = clamp(y, warp.params.z, warp.params.w);
      float theta = k * (yc - warp.params.y);
      float c = cos(theta), s = sin(theta);
      float invK = 1.0 / k;
      float beyond = y - yc;
      p[a] = -s * (z - invK) + warp.params.y + c * beyond;
      p[b] = c * (z - invK) + invK + s * beyond;
      break;
    }
    default:
      break;
  }
  return p;
}

vec3 unpackColour(uint rgba) {
  return vec3(float(rgba & 0xffu) / 255.0, float((rgba >> 8) & 0xffu) / 255.0,
              float((rgba >> 16) & 0xffu) / 255.0);
}

bool outsideBox(BoxRecord box, vec3 p) {
  return p.x < box.lo.x || p.y < box.lo.y || p.z < box.lo.z || p.x > box.hi.x ||
         p.y > box.hi.y || p.z > box.hi.z;
}

bool outsideBoxAt(uint index, vec3 p) {
  return outsideBox(programBoxes[index], p);
}

// Two evaluators over the same primitive and warp formulas, each instantiated with and without
// colour (the field-only path does no colour work): the stackless register machine and the
// stack-based tree walk (vk/stack_program.h). Specialization constant 1 picks one per pipeline.

const uint TREE_LEAF = 1u;
const uint TREE_OP = 2u;
const uint TREE_UNARY = 3u;
const uint TREE_BOX = 4u;
const uint TREE_WARP = 5u;
#define STACK_DEPTH 48

#define EVAL_PARAMS vec3 p, uint n
#define EVAL_COLOUR 0
#define EVAL_NAME evaluateRegisters
#include "eval_body.glsl"
#undef EVAL_NAME
#define EVAL_NAME evaluateTree
#include "eval_stack_body.glsl"
#undef EVAL_NAME
#undef EVAL_COLOUR
#undef EVAL_PARAMS
#define EVAL_PARAMS vec3 p, uint n, out vec3 colour
#define EVAL_COLOUR 1
#define EVAL_NAME evaluateRegistersColour
#include "eval_body.glsl"
#undef EVAL_NAME
#define EVAL_NAME evaluateTreeColour
#include "eval_stack_body.glsl"
#undef EVAL_NAME
#undef EVAL_COLOUR
#undef EVAL_PARAMS

float evaluateField(vec3 p, uint n) {
  return TRAVERSAL == 1u ? evaluateTree(p, n) : evaluateRegisters(p, n);
}

float evaluateFieldColour(vec3 p, uint n, out vec3 colour) {
  return TRAVERSAL == 1u ? evaluateTreeColour(p, n, colour) : evaluateRegistersColour(p, n, colour);
}

#endif  // BLOBVK_EVAL_PROGRAM_GLSL
