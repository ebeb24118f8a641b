#version 450
// Sparse extraction, pass 3 beside brick_field_rows.comp: the inside bits of the rows whose columns
// a host bound proved on one side of the iso-value (vk/extract/row_culling.h), all R points or
// none. Their samples are neither evaluated nor read.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Fills { uint fills[]; };  // batch row << 1 | inside
layout(std430, set = 0, binding = 1) writeonly buffer Masks { uint masks[]; };

layout(push_constant) uniform Push {
  uint count;  // entries of `fills`
  uint R;      // points a row
} pc;

void main() {
  uint i = linearInvocation();
  if (i >= pc.count) return;
  uint f = fills[i];
  masks[f >> 1] = (f & 1u) != 0u ? (1u << pc.R) - 1u : 0u;
}
