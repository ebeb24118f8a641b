#version 450
// Per cell of a slab: its triangles at the scanned offset, in case-table order. A vertex index
// is the scanned vertex offset of the edge's start point plus the edge's rank among that point's
// crossing edges (x, then y, then z): the global edge-key order of the CPU reference.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "grid_dispatch.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cases { uint cases[]; };
layout(std430, set = 0, binding = 2) readonly buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = 3) readonly buffer VertexOffsets { uint vertexOffsets[]; };
layout(std430, set = 0, binding = 4) readonly buffer TriOffsets { uint triOffsets[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Indices { uint indices[]; };

layout(push_constant) uniform Push {
  uint nx, ny;
  uint cellsX, cellsY;
  uint vertexBase;   // global index of the slab's first vertex
  uint triangleCapacity;  // triangles the index buffer holds (slab-local); later ones are dropped
} pc;

// Invocation (i, j, l): cell (i, j) of the slab's cell layer l.
void main() {
  uint i = gl_GlobalInvocationID.x, j = gl_GlobalInvocationID.y, l = gl_GlobalInvocationID.z;
  if (i >= pc.cellsX || j >= pc.cellsY) return;
  uint c = (l * pc.cellsY + j) * pc.cellsX + i;
  uint p = i + pc.nx * (j + pc.ny * l);
  uint layer = pc.nx * pc.ny;
  uint config = 0u;
  for (uint corner = 0u; corner < 8u; ++corner) {
    uint q = p + (corner & 1u) + pc.nx * ((corner >> 1) & 1u) + layer * ((corner >> 2) & 1u);
    if (field[q] >= ISO_VALUE) config |= 1u << corner;
  }
  uint first = triOffsets[c];
  // Only the triangles that fit the caller's buffer (emit_limits.comp flags the overflow).
  uint n = min(cases[config * 20u], first < pc.triangleCapacity ? pc.triangleCapacity - first : 0u);
  uint out_ = first * 3u;
  for (uint v = 0u; v < n * 3u; ++v) {
    uint e = cases[config * 20u + 1u + v];
    uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
    uvec3 start = axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u));
    uint q = p + start.x + pc.nx * start.y + layer * start.z;
    uint rank = bitCount(flags[q] & ((1u << axis) - 1u));
    indices[out_ + v] = pc.vertexBase + vertexOffsets[q] + rank;
  }
}
