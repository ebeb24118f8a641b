#version 450
// Sparse extraction, pass 6: per row of cells of an active brick (brick_layout.glsl), one
// invocation writes the row's triangles at its scanned offset, cell by cell in case-table order.
// A vertex index is the scanned vertex offset of the segment holding the edge's start point (in
// the brick that owns that point, maybe a neighbour), plus the point's prefix in its row, plus
// the edge's rank among the point's crossing edges: the global edge-key order of the CPU
// reference. Invocation x is the row (y + z * B), y + z * (groups in y) the active brick.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 2) readonly buffer Cases { uint cases[]; };
layout(std430, set = 0, binding = 3) readonly buffer Points { uint points[]; };
layout(std430, set = 0, binding = 4) readonly buffer VertexSegments { uint vertexSegments[]; };  // scanned
layout(std430, set = 0, binding = 5) readonly buffer TriangleSegments { uint triangleSegments[]; };  // scanned
layout(std430, set = 0, binding = 6) writeonly buffer Indices { uint indices[]; };
#define BRICK_SCAN_BINDING 7
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;   // cells per axis, w = log2(B)
  uvec4 bricks;  // bricks per axis, w = active bricks
} pc;

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u, P = R * R * R;
  uint r = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= B * B || a >= pc.bricks.w) return;
  uint ly = r & (B - 1u), lz = r >> pc.cells.w;
  uvec3 b = unpackBrick(bricks[a]);
  uvec3 g0 = b << pc.cells.w;
  if (g0.y + ly >= pc.cells.y || g0.z + lz >= pc.cells.z) return;
  uint out_ = triangleSegments[segmentPosition(a, b, pc.bricks.xyz, ly, lz, B)] * 3u;
  uint base = a * P + (lz * R + ly) * R;
  uvec3 lastBrick = pc.bricks.xyz - 1u;
  for (uint lx = 0u; lx < B && g0.x + lx < pc.cells.x; ++lx) {
    uint p = base + lx, config = 0u;
    for (uint corner = 0u; corner < 8u; ++corner) {
      uint q = p + (corner & 1u) + R * ((corner >> 1) & 1u) + R * R * ((corner >> 2) & 1u);
      if (field[q] >= ISO_VALUE) config |= 1u << corner;
    }
    uint n = cases[config * 20u] * 3u;
    for (uint v = 0u; v < n; ++v) {
      uint e = cases[config * 20u + 1u + v];
      uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
      uvec3 start = axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u));
      // The edge's start point and the brick that owns it (brick_layout.glsl).
      uvec3 g = g0 + uvec3(lx, ly, lz) + start;
      uvec3 owner = min(g >> pc.cells.w, lastBrick);
      uvec3 local = g - (owner << pc.cells.w);
      uint ownerNumber = brickScan[(owner.z * pc.bricks.y + owner.y) * pc.bricks.x + owner.x];
      uint word = points[ownerNumber * P + (local.z * R + local.y) * R + local.x];
      uint rank = bitCount((word & 7u) & ((1u << axis) - 1u));
      uint segment = segmentPosition(ownerNumber, owner, pc.bricks.xyz, local.y, local.z, R);
      indices[out_ + v] = vertexSegments[segment] + (word >> 3) + rank;
    }
    out_ += n;
  }
}
