#version 450
// Per cell of a slab: its marching-cubes configuration (bit c = corner c inside, corner c at
// offset (c & 1, c >> 1 & 1, c >> 2 & 1)) and the triangle count from the case table.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "grid_dispatch.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cases { uint cases[]; };  // 20 per config
layout(std430, set = 0, binding = 2) writeonly buffer TriCounts { uint triCounts[]; };

layout(push_constant) uniform Push {
  uint nx, ny;            // points per axis
  uint cellsX, cellsY;
} pc;

// Invocation (i, j, l): cell (i, j) of the slab's cell layer l.
void main() {
  uint i = gl_GlobalInvocationID.x, j = gl_GlobalInvocationID.y, l = gl_GlobalInvocationID.z;
  if (i >= pc.cellsX || j >= pc.cellsY) return;
  uint c = (l * pc.cellsY + j) * pc.cellsX + i;
  uint p = i + pc.nx * (j + pc.ny * l);
  uint config = 0u;
  for (uint corner = 0u; corner < 8u; ++corner) {
    uint q = p + (corner & 1u) + pc.nx * ((corner >> 1) & 1u) + pc.nx * pc.ny * ((corner >> 2) & 1u);
    if (field[q] >= ISO_VALUE) config |= 1u << corner;
  }
  triCounts[c] = cases[config * 20u];
}
