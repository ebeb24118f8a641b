// Body of the stackless evaluator, included twice by eval_program.glsl (EVAL_COLOUR 0 / 1).
// No include guard on purpose.
float EVAL_NAME(EVAL_PARAMS) {
  float reg[MAX_FIELD_REGISTERS];
#if EVAL_COLOUR
  vec3 col[MAX_FIELD_REGISTERS];
#endif
  vec3 pts[MAX_POINT_REGISTERS];
  pts[0] = p;
  reg[0] = 0.0;
#if EVAL_COLOUR
  col[0] = vec3(0.0);
#endif
  for (uint pc = 0u; pc < n; ++pc) {
    uvec4 in_ = programCode[pc].code;
    uint op = in_.x & 0xffu;
    uint dst = in_.x >> 8;
    switch (op) {
      case OP_PRIM:
        reg[dst] = primitiveField(in_.y, pts[in_.z]);
#if EVAL_COLOUR
        col[dst] = unpackColour(programPrims[in_.y].meta.z);
#endif
        break;
      case OP_ADD: {
        float a = reg[dst], b = reg[in_.y];
#if EVAL_COLOUR
        float wa = max(a, 0.0), wb = max(b, 0.0);
        float w = wa + wb;
        if (w > 0.0) col[dst] = (col[dst] * wa + col[in_.y] * wb) / w;
#endif
        reg[dst] = a + b;
        break;
      }
      case OP_MAX:
#if EVAL_COLOUR
        if (reg[in_.y] > reg[dst]) col[dst] = col[in_.y];
#endif
        reg[dst] = max(reg[dst], reg[in_.y]);
        break;
      case OP_MIN:
#if EVAL_COLOUR
        if (reg[in_.y] < reg[dst]) col[dst] = col[in_.y];
#endif
        reg[dst] = min(reg[dst], reg[in_.y]);
        break;
      case OP_DIFF: {
        float cut = 1.0 - reg[in_.y];
#if EVAL_COLOUR
        if (cut < reg[dst]) col[dst] = col[in_.y];
#endif
        reg[dst] = min(reg[dst], cut);
        break;
      }
      case OP_SDIFF: {
        float keep = 1.0 - reg[in_.y];
#if EVAL_COLOUR
        if (keep < reg[dst]) col[dst] = col[in_.y];
#endif
        reg[dst] = reg[dst] * keep;
        break;
      }
      case OP_ONE_MINUS:
        reg[dst] = 1.0 - reg[dst];
        break;
      case OP_MUL:
#if EVAL_COLOUR
        if (reg[in_.y] < reg[dst]) col[dst] = col[in_.y];
#endif
        reg[dst] = reg[dst] * reg[in_.y];
        break;
      case OP_POW:
      {
        // GLSL leaves pow(0, y) undefined; the C++ std::pow gives 0 for y > 0 (Ricci: y > 0).
        float base = max(reg[dst], 0.0);
        reg[dst] = base > 0.0 ? pow(base, uintBitsToFloat(in_.w)) : 0.0;
      }
        break;
      case OP_WARP:
        pts[dst] = applyWarp(in_.y, pts[in_.z]);
        break;
      case OP_SKIP:
        if (outsideBox(programBoxes[in_.y], pts[in_.z])) {
          reg[dst] = 0.0;
#if EVAL_COLOUR
          col[dst] = vec3(0.0);
#endif
          pc = in_.w - 1u;  // the loop's ++pc lands on the target
        }
        break;
      default:
        break;
    }
  }
#if EVAL_COLOUR
  colour = col[0];
#endif
  return reg[0];
}
