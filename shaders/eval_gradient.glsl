// The analytic gradient of a Program (field, gradient and colour in one pass): GLSL twin of
// blobtree/evaluate_gradient.cpp, same formulas (eval_gradient_formulas.glsl) in the same order.
// Used at vertices only (edge_vertex.glsl). This file is the interpreter over the Program's
// buffers: kernels built around the interpreter use it, and so do kernels built around specialised
// code that brings no gradient of its own (the specialised evaluator's register code and records
// are still bound: vk::uploadProgram puts the instructions first). Specialised code that generates
// its gradient (vk/eval/gradient_codegen.h) defines BLOBVK_GENERATED_GRADIENT and its own
// evaluateGradient, and this file adds nothing.
// The stack-based traversal uploads a tree encoding instead; its kernels keep central differences.
// Include after eval_program.glsl or the generated evaluator, with PROGRAM_SET/PROGRAM_BINDING set.
#ifndef BLOBVK_EVAL_GRADIENT_GLSL
#define BLOBVK_EVAL_GRADIENT_GLSL
#ifndef BLOBVK_GENERATED_GRADIENT

#include "program_layout.h"
#ifndef EVAL_CODE_BEGIN
#define EVAL_CODE_BEGIN 0u
#endif

// What the program contains, so that code for absent opcodes, primitive and warp types folds
// away (llvmpipe compiles and runs every branch it cannot prove dead): the interpreter's
// specialization constants, or the GRADIENT_* literals the specialised evaluator's generated
// source defines (vk/eval/program_codegen.cpp).
#ifdef BLOBVK_EVAL_INTERPRETER
#define GRAD_HAS_OP(o) HAS_OP(o)
#define GRAD_HAS_PRIM(t) HAS_PRIM(t)
#define GRAD_HAS_WARP(t) HAS_WARP(t)
#define GRAD_HAS_MATRIX ((PRIM_MASK & MASK_HAS_MATRIX) != 0u)
#define GRAD_WARP_HAS_MATRIX ((WARP_MASK & MASK_HAS_MATRIX) != 0u)
#else
#define GRAD_HAS_OP(o) ((GRADIENT_OP_MASK & (1u << (o))) != 0u)
#define GRAD_HAS_PRIM(t) ((GRADIENT_PRIM_MASK & (1u << (t))) != 0u)
#define GRAD_HAS_WARP(t) ((GRADIENT_WARP_MASK & (1u << (t))) != 0u)
#define GRAD_HAS_MATRIX ((GRADIENT_PRIM_MASK & 0x80000000u) != 0u)
#define GRAD_WARP_HAS_MATRIX ((GRADIENT_WARP_MASK & 0x80000000u) != 0u)
#define FIELD_REGS GRADIENT_FIELD_REGS
#endif
#include "eval_registers.glsl"

#ifndef BLOBVK_EVAL_INTERPRETER
// The generated evaluator declares no record buffers: bind them here (aliasing its own view of
// binding PROGRAM_BINDING + 0, which holds the instructions first).
#include "eval_formulas.glsl"
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 0) readonly buffer GradientCode { Instruction programCode[]; };
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 1) readonly buffer GradientPrims { PrimitiveRecord programPrims[]; };
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 2) readonly buffer GradientMatrices { MatrixRecord programMatrices[]; };
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 3) readonly buffer GradientBoxes { BoxRecord programBoxes[]; };
layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 4) readonly buffer GradientWarps { WarpRecord programWarps[]; };
#endif

#define GRADIENT_FORMULA_HAS_PRIM(t) GRAD_HAS_PRIM(t)
#define GRADIENT_FORMULA_HAS_WARP(t) GRAD_HAS_WARP(t)
#include "eval_gradient_formulas.glsl"

// Field of primitive `index` at p; its gradient (in p's space) in `grad`.
precise float primitiveGradient(uint index, vec3 p, out vec3 grad) {
  uvec4 meta = programPrims[index].meta;
  bool matrix = GRAD_HAS_MATRIX && meta.y != 0u;
  if (matrix) {
    MatrixRecord m = programMatrices[meta.y];
    p = toLocalRows(m.r0, m.r1, m.r2, p);
  }
  precise vec3 g_;
  precise float field = primitiveGradientOf(meta.x, p, programPrims[index].p0, programPrims[index].p1,
                                            programPrims[index].p2, g_);
  if (matrix) {
    MatrixRecord m = programMatrices[meta.y];
    g_ = transposeTimesRows(m.r0, m.r1, m.r2, g_);
  }
  grad = g_;
  return field;
}

// Warp `index` at p; (j0, j1, j2) replaced by J_warp(p) * J (its matrix included).
precise vec3 applyWarpJacobian(uint index, vec3 p, inout vec3 j0, inout vec3 j1, inout vec3 j2) {
  WarpRecord warp = programWarps[index];
  precise mat3 jin = transpose(mat3(j0, j1, j2));  // columns = rows of J
  if (GRAD_WARP_HAS_MATRIX && warp.meta.w != 0u) {
    MatrixRecord m = programMatrices[warp.meta.w];
    p = toLocalRows(m.r0, m.r1, m.r2, p);
    jin = transpose(mat3(m.r0.xyz, m.r1.xyz, m.r2.xyz)) * jin;
  }
  return warpJacobianOf(warp.meta.x, warp.meta.y, warp.meta.z, warp.params, p, jin, 0.0, j0, j1, j2);
}

// Field at p, its gradient and (when wanted) its colour: blobtree::evaluateGradientColour.
// Registers are scalar variables selected by index (eval_registers.glsl), as in eval_body.glsl.
precise float evaluateGradient(vec3 p, uint n, bool wantColour, out vec3 gradient, out vec3 colour) {
  REG_DECL(float, r, 0.0)
  REG_DECL(precise vec3, g, vec3(0.0))
  REG_DECL(precise vec3, c, vec3(0.0))
  const bool warps = GRAD_HAS_OP(OP_WARP);
  precise vec3 pts[MAX_POINT_REGISTERS];  // with their Jacobians' rows: only used when the program warps
  precise vec3 ja[MAX_POINT_REGISTERS], jb[MAX_POINT_REGISTERS], jc[MAX_POINT_REGISTERS];
  if (warps) {
    for (uint i = 0u; i < MAX_POINT_REGISTERS; ++i) {
      pts[i] = p;
      ja[i] = vec3(1.0, 0.0, 0.0);
      jb[i] = vec3(0.0, 1.0, 0.0);
      jc[i] = vec3(0.0, 0.0, 1.0);
    }
  }
  for (uint pc_ = EVAL_CODE_BEGIN; pc_ < n; ++pc_) {
    uvec4 in_ = programCode[pc_].code;
    uint op = in_.x & 0xffu;
    uint dst = in_.x >> 8;
    uint pz = warps ? min(in_.z, MAX_POINT_REGISTERS - 1u) : 0u;
    vec3 at = warps ? pts[pz] : p;
    float a, b;
    vec3 ga, gb, ca, cb;
    REG_READ(a, r, dst)
    REG_READ(b, r, in_.y)
    REG_READ(ga, g, dst)
    REG_READ(gb, g, in_.y)
    REG_READ(ca, c, dst)
    REG_READ(cb, c, in_.y)
    precise float v = a;
    precise vec3 gv = ga, cv = ca;
    if (GRAD_HAS_OP(OP_PRIM) && op == OP_PRIM) {
      precise vec3 gl;
      v = primitiveGradient(in_.y, at, gl);
      gv = pz == 0u ? gl : jacobianTransposeTimes(ja[pz], jb[pz], jc[pz], gl);
      if (wantColour) cv = unpackColour(programPrims[in_.y].meta.z);
    }
    if (GRAD_HAS_OP(OP_ADD) && op == OP_ADD) {
      if (wantColour) {
        float wa = max(a, 0.0), wb = max(b, 0.0);
        float w = wa + wb;
        if (w > 0.0) cv = (ca * wa + cb * wb) / w;
      }
      v = a + b;
      gv = ga + gb;
    }
    if ((GRAD_HAS_OP(OP_MAX) && op == OP_MAX) || (GRAD_HAS_OP(OP_MIN) && op == OP_MIN) ||
        (GRAD_HAS_OP(OP_DIFF) && op == OP_DIFF)) {
      float other = op == OP_DIFF ? 1.0 - b : b;
      bool take = op == OP_MAX ? other > a : other < a;
      if (take) {
        cv = cb;
        gv = op == OP_DIFF ? -gb : gb;
      }
      v = op == OP_MAX ? max(a, other) : min(a, other);
    }
    if ((GRAD_HAS_OP(OP_SDIFF) && op == OP_SDIFF) || (GRAD_HAS_OP(OP_MUL) && op == OP_MUL)) {
      float other = op == OP_SDIFF ? 1.0 - b : b;
      if (other < a) cv = cb;
      gv = op == OP_SDIFF ? ga * other - gb * a : ga * other + gb * a;
      v = a * other;
    }
    if (GRAD_HAS_OP(OP_ONE_MINUS) && op == OP_ONE_MINUS) {
      v = 1.0 - a;
      gv = -ga;
    }
    if (GRAD_HAS_OP(OP_POW) && op == OP_POW) {
      float base = max(a, 0.0);
      float e = uintBitsToFloat(in_.w);
      v = powField(base, e);  // a flushed result has derivative 0 (blobtree::powDerivative)
      precise float derivative = base > 0.0 ? e * v / base : 0.0;
      gv = ga * derivative;
    }
    if (warps && op == OP_WARP) {
      uint d = min(dst, MAX_POINT_REGISTERS - 1u);
      precise vec3 j0 = ja[pz], j1 = jb[pz], j2 = jc[pz];
      precise vec3 q = applyWarpJacobian(in_.y, at, j0, j1, j2);
      pts[d] = q;
      ja[d] = j0;
      jb[d] = j1;
      jc[d] = j2;
    }
    if (GRAD_HAS_OP(OP_NULL_ADDS) && op == OP_NULL_ADDS) {
      // The pairs' bits (vk/eval/gradient_codegen.cpp, nullAdds, generates the same): the zeros
      // come from the instruction word (z's top bit is clear), so no compiler folds a + 0 into a.
      precise float zero = uintBitsToFloat(in_.z >> 31);
      uvec3 negative = (uvec3(in_.z, in_.z >> 1, in_.z >> 2) & 1u) << 31;
      if (wantColour) {
        float wa = max(a, 0.0), wb = max(zero, 0.0);
        float w = wa + wb;
        vec3 cz = unpackColour(programPrims[in_.y].meta.z);
        if (w > 0.0) {
          for (uint k = 0u; k < in_.w; ++k) {
            EVAL_LOOP_TICK();
            precise vec3 next = (cv * wa + cz * wb) / w;
            if (all(equal(floatBitsToUint(next), floatBitsToUint(cv)))) break;
            cv = next;
          }
        }
      }
      v = a + zero;
      gv = ga + uintBitsToFloat(negative | floatBitsToUint(vec3(zero)));
    }
    if (GRAD_HAS_OP(OP_SKIP) && op == OP_SKIP) {
      BoxRecord box = programBoxes[in_.y];
      if (outsideBoxBounds(box.lo.xyz, box.hi.xyz, at)) {
        v = 0.0;
        gv = vec3(0.0);
        cv = vec3(0.0);
        pc_ = in_.w - 1u;  // per lane: vertices are few, divergence is cheap here
      }
    }
    REG_WRITE(r, dst, v)
    REG_WRITE(g, dst, gv)
    REG_WRITE(c, dst, cv)
  }
  gradient = n > 0u ? g0 : vec3(0.0);
  colour = n > 0u ? c0 : vec3(0.0);
  return n > 0u ? r0 : 0.0;
}

#endif  // !BLOBVK_GENERATED_GRADIENT
#endif  // BLOBVK_EVAL_GRADIENT_GLSL
