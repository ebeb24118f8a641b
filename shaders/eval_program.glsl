// The stackless register-machine evaluator of a compiled Program: GLSL twin of
// blobtree/evaluate.cpp (same float operations in the same order; keep them in step).
//
// The includer defines PROGRAM_SET (descriptor set, usually 0) and PROGRAM_BINDING (first of five
// consecutive bindings: code, primitives, matrices, boxes, warps), then includes this file before
// any other code (it enables GL_KHR_shader_subgroup_vote). A kernel that calls only evaluateField
// defines EVALUATOR_FIELD_ONLY first, one that calls only evaluateGradient EVALUATOR_GRADIENT_ONLY:
// the generated evaluator (vk/eval/program_codegen.cpp) then leaves the other functions out, which
// glslang would otherwise keep and the driver compile (this interpreter ignores both).
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
// This interpreter, not the generated evaluator that replaces it (which declares no record
// buffers and no TRAVERSAL): eval_gradient.glsl and vertex_emit.glsl test it.
#define BLOBVK_EVAL_INTERPRETER 1

#extension GL_KHR_shader_subgroup_vote : require

// Where the code starts: 0, or with EVAL_TAPES the first instruction of the tape the kernel set in
// evalTapeBegin (per-brick tapes, vk/eval/region_tape.h; the `n` the evaluators take is then the
// tape's end). It must be the same across a subgroup (the instruction counter is uniform).
#ifdef EVAL_TAPES
uint evalTapeBegin = 0u;
#define EVAL_CODE_BEGIN evalTapeBegin
#else
#define EVAL_CODE_BEGIN 0u
#endif

#include "program_layout.h"
#include "eval_loop_count.glsl"

layout(constant_id = 1) const uint TRAVERSAL = 0u;  // 0 stackless, 1 stack-based
layout(constant_id = 2) const uint FIELD_REGS = 32u;
#include "program_masks.glsl"

#include "eval_registers.glsl"

#ifdef EVAL_RECORDS_UNIFORM
// The code and records in uniform blocks of 64 KB (the host binds ranges of that size): llvmpipe
// reads a uniform block with a vector gather, a storage buffer with a loop over the lanes with a
// branch per lane and component (per-brick tapes, whose code and records fit: brick_tapes.h).
layout(std140, set = PROGRAM_SET, binding = PROGRAM_BINDING + 0) uniform ProgramCode { Instruction programCode[4096]; };
layout(std140, set = PROGRAM_SET, binding = PROGRAM_BINDING + 1) uniform ProgramPrims { PrimitiveRecord programPrims[1024]; };
layout(std140, set = PROGRAM_SET, binding = PROGRAM_BINDING + 2) uniform ProgramMatrices { MatrixRecord programMatrices[1365]; };
layout(std140, set = PROGRAM_SET, binding = PROGRAM_BINDING + 3) uniform ProgramBoxes { BoxRecord programBoxes[2048]; };
layout(std140, set = PROGRAM_SET, binding = PROGRAM_BINDING + 4) uniform ProgramWarps { WarpRecord programWarps[2048]; };
#else
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

#endif

#include "eval_formulas.glsl"

vec3 toLocal(MatrixRecord m, vec3 p) { return toLocalRows(m.r0, m.r1, m.r2, p); }

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
  if (HAS_PRIM(PRIM_POINT) && type == PRIM_POINT) dd = ddPoint(p, p0);
  if (HAS_PRIM(PRIM_LINE) && type == PRIM_LINE) dd = ddLine(p, p0, programPrims[index].p1);
  if (HAS_PRIM(PRIM_CYLINDER) && type == PRIM_CYLINDER)
    dd = ddCylinder(p, p0, programPrims[index].p1.xyz, programPrims[index].p2.x, programPrims[index].p2.y);
  if (HAS_PRIM(PRIM_DISC) && type == PRIM_DISC)
    dd = ddDisc(p, p0, programPrims[index].p1.xyz, programPrims[index].p2.x);
  if (HAS_PRIM(PRIM_RING) && type == PRIM_RING)
    dd = ddRing(p, p0, programPrims[index].p1.xyz, programPrims[index].p2.x);
  if (HAS_PRIM(PRIM_CUBE) && type == PRIM_CUBE) dd = ddCube(p, p0, programPrims[index].p1.xyz);
  if (HAS_PRIM(PRIM_TRIANGLE) && type == PRIM_TRIANGLE)
    dd = triangleDistance2(p, p0, programPrims[index].p1.xyz, programPrims[index].p2.xyz);
  if (HAS_PRIM(PRIM_QUADRIC) && type == PRIM_QUADRIC) return quadricField(p, p0, programPrims[index].p0.w);
  return wyvill(dd);
}

vec3 applyWarp(uint index, vec3 p) {
  WarpRecord warp = programWarps[index];
  if ((WARP_MASK & MASK_HAS_MATRIX) != 0u && warp.meta.w != 0u)
    p = toLocal(programMatrices[warp.meta.w], p);
  uint a = warp.meta.y, b = warp.meta.z;
  switch (warp.meta.x) {
    case WARP_TWIST:
      if (HAS_WARP(WARP_TWIST)) p = warpTwist(p, a, warp.params.x);
      break;
    case WARP_TAPER:
      if (HAS_WARP(WARP_TAPER)) p = warpTaper(p, a, b, warp.params.x);
      break;
    case WARP_SHEAR:
      if (HAS_WARP(WARP_SHEAR)) p = warpShear(p, a, b, warp.params.x);
      break;
    case WARP_BEND:
      if (HAS_WARP(WARP_BEND)) p = warpBend(p, a, b, warp.params);
      break;
    default:
      break;
  }
  return p;
}

bool outsideBox(BoxRecord box, vec3 p) { return outsideBoxBounds(box.lo.xyz, box.hi.xyz, p); }

bool outsideBoxAt(uint index, vec3 p) {
  return outsideBox(programBoxes[index], p);
}

// Two evaluators over the same primitive and warp formulas, each instantiated with and without
// colour (the field-only path does no colour work): the stackless register machine and the
// stack-based tree walk (vk/eval/stack_program.h). Specialization constant 1 picks one per pipeline.

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
