#version 450
// Sparse extraction, pass 4: per row of points of an active brick (brick_layout.glsl), one
// invocation packs which of the row's R samples are inside (f >= iso, as in the CPU reference)
// into bit x of one word. Every later pass reads these words, not the field: llvmpipe pays a
// load per lane per float, and a row's crossing edges and cell configurations are a few bit
// operations on four words. Invocation x is the row (y + z * R), y + z * (groups in y) the brick.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Masks { uint masks[]; };

layout(push_constant) uniform Push {
  uint log2B;
  uint activeBricks;
} pc;

void main() {
  uint R = (1u << pc.log2B) + 1u;
  uint r = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || a >= pc.activeBricks) return;
  uint base = (a * R * R + r) * R;
  uint m = 0u;
  for (uint x = 0u; x < R; ++x)
    if (field[base + x] >= ISO_VALUE) m |= 1u << x;
  masks[a * R * R + r] = m;
}
