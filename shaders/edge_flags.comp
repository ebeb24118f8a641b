#version 450
// Per grid point of a slab: which of its three "upper" edges (+x bit 0, +y bit 1, +z bit 2)
// cross the iso value, and how many (the value the vertex scan sums). Inside is f >= iso, as in
// the CPU reference.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "grid_dispatch.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Counts { uint counts[]; };

layout(push_constant) uniform Push {
  uint nx, ny;            // points per axis
  uint cellsX, cellsY, cellsZ;
  uint k0;                // global z of slab layer 0
} pc;

// Invocation (i, j, l): point (i, j, k0 + l) of the slab, l < the dispatch's layers.
void main() {
  uint i = gl_GlobalInvocationID.x, j = gl_GlobalInvocationID.y, l = gl_GlobalInvocationID.z;
  if (i >= pc.nx || j >= pc.ny) return;
  uint k = pc.k0 + l;
  uint idx = (l * pc.ny + j) * pc.nx + i;
  bool inside = field[idx] >= ISO_VALUE;
  uint bits = 0u;
  if (i < pc.cellsX && (field[idx + 1u] >= ISO_VALUE) != inside) bits |= 1u;
  if (j < pc.cellsY && (field[idx + pc.nx] >= ISO_VALUE) != inside) bits |= 2u;
  if (k < pc.cellsZ && (field[idx + pc.nx * pc.ny] >= ISO_VALUE) != inside) bits |= 4u;
  flags[idx] = bits;
  counts[idx] = bitCount(bits);
}
