// Body of the stackless evaluator, included twice by eval_program.glsl (EVAL_COLOUR 0 / 1).
// No include guard on purpose.
//
// Shaped for SIMD execution (llvmpipe's 8-wide lanes, GPU subgroups):
// - the instruction counter stays uniform across the subgroup, so every lane reads the same
//   instruction (a scalar load) and runs the same opcode. An OP_SKIP whose box some lanes are
//   inside and others outside does not branch per lane: the outside lanes write 0, become
//   inactive until the skip target (`resume`) and have their register writes masked; the whole
//   subgroup jumps only when every lane is outside (subgroupAll);
// - registers live in scalar variables selected by index (eval_registers.glsl), not a scratch
//   array; opcodes, primitive and warp types the program lacks fold away (OP_MASK, PRIM_MASK,
//   WARP_MASK).
// Results are those of blobtree/evaluate.cpp operation for operation.
// precise: no fused multiply-add anywhere in the field or its colour blend (eval_formulas.glsl).
precise float EVAL_NAME(EVAL_PARAMS) {
  REG_DECL(float, r, 0.0)
#if EVAL_COLOUR
  REG_DECL(vec3, c, vec3(0.0))
#endif
  vec3 pts[MAX_POINT_REGISTERS];  // only read when the program has warps
  pts[0] = p;
  uint resume = 0u;  // this lane skips the instructions before `resume`
  for (uint pc = EVAL_CODE_BEGIN; pc < n; ++pc) {
    EVAL_LOOP_TICK();
    uvec4 in_ = programCode[pc].code;
    uint op = in_.x & 0xffu;
    uint dst = in_.x >> 8;
    vec3 at = HAS_OP(OP_WARP) ? pts[min(in_.z, MAX_POINT_REGISTERS - 1u)] : p;
    float a, b;
    REG_READ(a, r, dst)
    REG_READ(b, r, in_.y)
    float v = a;
#if EVAL_COLOUR
    vec3 ca, cb;
    REG_READ(ca, c, dst)
    REG_READ(cb, c, in_.y)
    precise vec3 cv = ca;
#endif
    if (HAS_OP(OP_PRIM) && op == OP_PRIM) {
      v = primitiveField(in_.y, at);
#if EVAL_COLOUR
      cv = unpackColour(programPrims[in_.y].meta.z);
#endif
    }
    if (HAS_OP(OP_ADD) && op == OP_ADD) {
#if EVAL_COLOUR
      float wa = max(a, 0.0), wb = max(b, 0.0);
      float w = wa + wb;
      if (w > 0.0) cv = (ca * wa + cb * wb) / w;
#endif
      v = a + b;
    }
    if (HAS_OP(OP_MAX) && op == OP_MAX) {
#if EVAL_COLOUR
      if (b > a) cv = cb;
#endif
      v = max(a, b);
    }
    if (HAS_OP(OP_MIN) && op == OP_MIN) {
#if EVAL_COLOUR
      if (b < a) cv = cb;
#endif
      v = min(a, b);
    }
    if (HAS_OP(OP_DIFF) && op == OP_DIFF) {
      float cut = 1.0 - b;
#if EVAL_COLOUR
      if (cut < a) cv = cb;
#endif
      v = min(a, cut);
    }
    if (HAS_OP(OP_SDIFF) && op == OP_SDIFF) {
      float keep = 1.0 - b;
#if EVAL_COLOUR
      if (keep < a) cv = cb;
#endif
      v = a * keep;
    }
    if (HAS_OP(OP_ONE_MINUS) && op == OP_ONE_MINUS) v = 1.0 - a;
    if (HAS_OP(OP_MUL) && op == OP_MUL) {
#if EVAL_COLOUR
      if (b < a) cv = cb;
#endif
      v = a * b;
    }
    if (HAS_OP(OP_POW) && op == OP_POW) v = powField(a, uintBitsToFloat(in_.w));
    bool live = true;
    if (HAS_OP(OP_SKIP)) {
      live = pc >= resume;
      if (op == OP_SKIP) {
        bool outside = live && outsideBoxAt(in_.y, at);
        if (outside) {
          v = 0.0;
#if EVAL_COLOUR
          cv = vec3(0.0);
#endif
          resume = in_.w;
        }
        // Lanes already inactive sit in an enclosing skipped subtree whose target is at or
        // after this one, so the jump is safe for them too.
        if (subgroupAll(outside || !live)) pc = in_.w - 1u;  // the loop's ++pc lands on w
      }
    }
    if (HAS_OP(OP_WARP) && op == OP_WARP) {
      // Writes a point register; the field register write below rewrites reg[dst] unchanged.
      vec3 q = applyWarp(in_.y, at);
      if (live) pts[min(dst, MAX_POINT_REGISTERS - 1u)] = q;
    }
    if (HAS_OP(OP_SKIP) && !live) {
      v = a;
#if EVAL_COLOUR
      cv = ca;
#endif
    }
    REG_WRITE(r, dst, v)
#if EVAL_COLOUR
    REG_WRITE(c, dst, cv)
#endif
  }
#if EVAL_COLOUR
  colour = c0;
#endif
  return r0;
}
