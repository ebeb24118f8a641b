#version 450
// Sparse extraction, pass 6: one invocation per vertex of the mesh, in global edge-key order.
// Vertex v lies in the last segment (row of points of an active brick, brick_layout.glsl) whose
// scanned vertex offset is <= v (a binary search over the scan in global segment order), at the
// last point x of that row with rowVerticesBefore(x) <= the rest, on that point's
// (rest - rowVerticesBefore(x))-th crossing upper edge (x, then y, then z). The vertex itself:
// edge_vertex.glsl. Its edge key (global point index * 3 + axis) is written as two words, low first.
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"
#include "brick_layout.glsl"

layout(std430, set = 0, binding = 5) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 6) readonly buffer Edges { uvec4 edges[]; };  // brick_rows.comp
layout(std430, set = 0, binding = 7) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 8) readonly buffer VertexSegments { uint vertexSegments[]; };  // scanned
layout(std430, set = 0, binding = 9) readonly buffer VertexRows { uvec2 vertexRows[]; };
layout(std430, set = 0, binding = 10) writeonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Normals { float normals[]; };
layout(std430, set = 0, binding = 12) writeonly buffer Colours { float colours[]; };
layout(std430, set = 0, binding = 13) writeonly buffer Keys { uvec2 keys[]; };

layout(push_constant) uniform Push {
  vec4 originCell;
  uint codeLength;
  uint refineSteps;
  uint attributes;  // bit 0 normals, bit 1 colours
  float normalStep;
  uint log2B;
  uint segments;    // point rows in the scan
  uint vertices;    // the mesh's vertex count
  uint nx, ny;      // grid points per axis (edge keys)
} pc;

#include "edge_vertex.glsl"

void main() {
  uint v = linearInvocation();
  if (v >= pc.vertices) return;
  uint lo = 0u, hi = pc.segments;  // vertexSegments[lo] <= v < vertexSegments[hi] (or the end)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (vertexSegments[mid] <= v) lo = mid; else hi = mid;
  }
  uvec2 row = vertexRows[lo];
  uint R = (1u << pc.log2B) + 1u;
  uvec3 e = edges[row.x * R * R + row.y].xyz;
  uint rest = v - vertexSegments[lo];
  uint x0 = 0u, x1 = R;  // the last point of the row with rowVerticesBefore <= rest
  while (x1 - x0 > 1u) {
    uint mid = (x0 + x1) / 2u;
    if (rowVerticesBefore(e, mid) <= rest) x0 = mid; else x1 = mid;
  }
  uint bits = ((e.x >> x0) & 1u) | (((e.y >> x0) & 1u) << 1) | (((e.z >> x0) & 1u) << 2);
  uint rank = rest - rowVerticesBefore(e, x0);
  uint axis = findLSB(bits);
  if (rank > 0u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  if (rank > 1u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  uint lz = divideSmall(row.y, R), ly = row.y - lz * R;
  uvec3 g = (unpackBrick(bricks[row.x]) << pc.log2B) + uvec3(x0, ly, lz);
  uint idx = (row.x * R * R + row.y) * R + x0;
  emitEdgeVertex(v, g, axis, field[idx], field[idx + (axis == 0u ? 1u : (axis == 1u ? R : R * R))]);
  // Key = ((z * ny + y) * nx + x) * 3 + axis in 64 bits.
  uint khi, klo, carry;
  umulExtended(g.z * pc.ny + g.y, pc.nx, khi, klo);
  klo = uaddCarry(klo, g.x, carry);
  khi += carry;
  uint h3, l3;
  umulExtended(klo, 3u, h3, l3);
  khi = khi * 3u + h3;
  l3 = uaddCarry(l3, axis, carry);
  keys[v] = uvec2(l3, khi + carry);
}
