// Body of the stack-based tree walk (vk/eval/stack_program.h encoding), included twice by
// eval_program.glsl (EVAL_COLOUR 0 / 1). No include guard on purpose.
// precise: no fused multiply-add anywhere in the field or its colour blend (eval_formulas.glsl).
precise float EVAL_NAME(EVAL_PARAMS) {
  if (n == 0u) {
#if EVAL_COLOUR
    colour = vec3(0.0);
#endif
    return 0.0;
  }
  vec3 pts[MAX_POINT_REGISTERS];
  pts[0] = p;
  uint nodes[STACK_DEPTH];
  uint states[STACK_DEPTH];  // 0: entering; else 1 + the child being evaluated
  float vals[STACK_DEPTH];
#if EVAL_COLOUR
  vec3 cols[STACK_DEPTH];
#endif
  int sp = 0, vsp = 0;
  nodes[0] = 0u;
  states[0] = 0u;
  while (sp >= 0) {
    EVAL_LOOP_TICK();
    uint node = nodes[sp];
    uvec4 h = programCode[2u * node].code;
    uvec4 links = programCode[2u * node + 1u].code;
    uint kind = h.x & 0xffu, op = h.x >> 8;
    uint state = states[sp];
    if (kind == TREE_LEAF) {
      vals[vsp] = primitiveField(h.y, pts[h.z]);
#if EVAL_COLOUR
      cols[vsp] = unpackColour(programPrims[h.y].meta.z);
#endif
      ++vsp;
      --sp;
    } else if (kind == TREE_BOX || kind == TREE_WARP) {
      if (state != 0u) {
        --sp;
      } else if (kind == TREE_BOX && outsideBoxAt(h.y, pts[h.z])) {
        vals[vsp] = 0.0;
#if EVAL_COLOUR
        cols[vsp] = vec3(0.0);
#endif
        ++vsp;
        --sp;
      } else {
        if (kind == TREE_WARP) pts[h.z & 0xffu] = applyWarp(h.y, pts[h.z >> 8]);
        states[sp] = 1u;
        ++sp;
        nodes[sp] = links.x;
        states[sp] = 0u;
      }
    } else if (kind == TREE_UNARY) {
      if (state == 0u) {
        states[sp] = 1u;
        ++sp;
        nodes[sp] = links.x;
        states[sp] = 0u;
      } else {
        float v = vals[vsp - 1];
        if (op == OP_POW) {
          v = powField(v, uintBitsToFloat(h.y));
        } else {
          v = 1.0 - v;
        }
        vals[vsp - 1] = v;
        --sp;
      }
    } else {  // TREE_OP
      uint next = links.x;
      if (state != 0u) {
        uint child = state - 1u;
        if (child != links.x) {  // fold the child's value into the accumulator
          float a = vals[vsp - 2], b = vals[vsp - 1];
#if EVAL_COLOUR
          precise vec3 ca = cols[vsp - 2], cb = cols[vsp - 1];
#endif
          float r = a;
          if (op == OP_ADD) {
#if EVAL_COLOUR
            float wa = max(a, 0.0), wb = max(b, 0.0);
            float w = wa + wb;
            if (w > 0.0) ca = (ca * wa + cb * wb) / w;
#endif
            r = a + b;
          } else if (op == OP_MAX) {
#if EVAL_COLOUR
            if (b > a) ca = cb;
#endif
            r = max(a, b);
          } else if (op == OP_MIN) {
#if EVAL_COLOUR
            if (b < a) ca = cb;
#endif
            r = min(a, b);
          } else if (op == OP_DIFF) {
            float cut = 1.0 - b;
#if EVAL_COLOUR
            if (cut < a) ca = cb;
#endif
            r = min(a, cut);
          } else if (op == OP_SDIFF) {
            float keep = 1.0 - b;
#if EVAL_COLOUR
            if (keep < a) ca = cb;
#endif
            r = a * keep;
          } else if (op == OP_MUL) {
#if EVAL_COLOUR
            if (b < a) ca = cb;
#endif
            r = a * b;
          }
          vals[vsp - 2] = r;
#if EVAL_COLOUR
          cols[vsp - 2] = ca;
#endif
          --vsp;
        }
        next = programCode[2u * child + 1u].code.y;
      }
      if (next == 0xffffffffu) {
        --sp;
      } else {
        states[sp] = next + 1u;
        ++sp;
        nodes[sp] = next;
        states[sp] = 0u;
      }
    }
  }
#if EVAL_COLOUR
  colour = cols[0];
#endif
  return vals[0];
}
