// The brick classification's bound (brick_classify_body.glsl) as an interpreter of the register
// code: one loop over the instructions, any Program. Generated kernels replace this file with the
// Program's own straight-line code (vk/eval/interval_codegen.h), which must keep its semantics:
// skips, pending skips' widening to 0 and giving up past MAX_PENDING nested partial skips.
#ifndef BLOBVK_BRICK_CLASSIFY_BOUNDS_GLSL
#define BLOBVK_BRICK_CLASSIFY_BOUNDS_GLSL
const uint MAX_PENDING = 16u;

// Interval of the field over `query`; sets `gaveUp` when the bound gave up (too many
// partially covered skips nested).
vec2 fieldBounds(Box query, out bool gaveUp) {
  vec2 reg[MAX_FIELD_REGISTERS];
  Box pts[MAX_POINT_REGISTERS];
  uvec2 pending[MAX_PENDING];  // (skip target, register): the register also takes 0 there
  uint pendingCount = 0u;
  for (uint r = 0u; r < MAX_FIELD_REGISTERS; ++r) reg[r] = vec2(0.0);
  for (uint r = 0u; r < MAX_POINT_REGISTERS; ++r) pts[r] = query;
  pts[0] = padBox(query);
  gaveUp = false;
  uint n = pc.bricks.w;
  uint at = 0u;
  for (;;) {
    while (pendingCount > 0u && pending[pendingCount - 1u].x <= at) {
      uint dst = pending[pendingCount - 1u].y;
      reg[dst] = vec2(min(reg[dst].x, 0.0), max(reg[dst].y, 0.0));
      --pendingCount;
    }
    if (at >= n) break;
    uvec4 in_ = programCode[at].code;
    uint op = in_.x & 0xffu, dst = min(in_.x >> 8, MAX_FIELD_REGISTERS - 1u);
    uint y = min(in_.y, MAX_FIELD_REGISTERS - 1u);
    vec2 d = reg[dst];
    if (HAS_OP(OP_PRIM) && op == OP_PRIM) {
      uvec4 meta = programPrims[in_.y].meta;
      d = primitiveBounds(in_.y, meta.x, meta.y, pts[min(in_.z, MAX_POINT_REGISTERS - 1u)]);
    } else if (HAS_OP(OP_ADD) && op == OP_ADD) {
      d += reg[y];
    } else if (HAS_OP(OP_MAX) && op == OP_MAX) {
      d = max(d, reg[y]);
    } else if (HAS_OP(OP_MIN) && op == OP_MIN) {
      d = min(d, reg[y]);
    } else if (HAS_OP(OP_DIFF) && op == OP_DIFF) {
      d = diffInterval(d, reg[y]);
    } else if (HAS_OP(OP_SDIFF) && op == OP_SDIFF) {
      d = sdiffInterval(d, reg[y]);
    } else if (HAS_OP(OP_ONE_MINUS) && op == OP_ONE_MINUS) {
      d = oneMinusInterval(d);
    } else if (HAS_OP(OP_MUL) && op == OP_MUL) {
      d = mulInterval(d, reg[y]);
    } else if (HAS_OP(OP_POW) && op == OP_POW) {
      d = powInterval(d, uintBitsToFloat(in_.w));
    } else if (HAS_OP(OP_WARP) && op == OP_WARP) {
      pts[min(dst, MAX_POINT_REGISTERS - 1u)] = warpBox(in_.y, programWarps[in_.y].meta, pts[min(in_.z, MAX_POINT_REGISTERS - 1u)]);
    } else if (HAS_OP(OP_SKIP) && op == OP_SKIP) {
      BoxRecord s = programBoxes[in_.y];
      Box q = pts[min(in_.z, MAX_POINT_REGISTERS - 1u)];
      if (skipMisses(s, q)) {
        reg[dst] = vec2(0.0);
        at = in_.w;
        continue;
      }
      if (!skipHolds(s, q)) {
        if (pendingCount == MAX_PENDING) {
          gaveUp = true;
          return vec2(-INF, INF);
        }
        pending[pendingCount++] = uvec2(in_.w, dst);
      }
    }
    reg[dst] = d;
    ++at;
    // A second, cheap slot: the next instruction when it is an operator (no primitive, warp or
    // skip) and no pending skip ends before it. llvmpipe runs every branch of the slot above under
    // a mask, the primitive's included; post-order code alternates primitives and operators
    // (random128: 128 of each), so a lane's vector of lanes in step takes half the passes.
    // The same operations in the same order: the same bound bit for bit.
    if (at < n && (pendingCount == 0u || pending[pendingCount - 1u].x > at)) {
      uvec4 next = programCode[at].code;
      uint op2 = next.x & 0xffu, dst2 = min(next.x >> 8, MAX_FIELD_REGISTERS - 1u);
      vec2 e = reg[min(next.y, MAX_FIELD_REGISTERS - 1u)];
      vec2 d2 = reg[dst2];
      bool cheap = true;
      if (HAS_OP(OP_ADD) && op2 == OP_ADD) {
        d2 += e;
      } else if (HAS_OP(OP_MAX) && op2 == OP_MAX) {
        d2 = max(d2, e);
      } else if (HAS_OP(OP_MIN) && op2 == OP_MIN) {
        d2 = min(d2, e);
      } else if (HAS_OP(OP_DIFF) && op2 == OP_DIFF) {
        d2 = diffInterval(d2, e);
      } else if (HAS_OP(OP_SDIFF) && op2 == OP_SDIFF) {
        d2 = sdiffInterval(d2, e);
      } else if (HAS_OP(OP_ONE_MINUS) && op2 == OP_ONE_MINUS) {
        d2 = oneMinusInterval(d2);
      } else if (HAS_OP(OP_MUL) && op2 == OP_MUL) {
        d2 = mulInterval(d2, e);
      } else {
        cheap = false;
      }
      if (cheap) {
        reg[dst2] = d2;
        ++at;
      }
    }
  }
  return n > 0u ? reg[0] : vec2(0.0);
}

#endif
