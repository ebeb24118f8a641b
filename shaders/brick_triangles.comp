#version 450
// Sparse extraction, pass 7: one invocation per triangle of the mesh, in cell order then
// case-table order. Triangle t lies in the last segment (row of cells of an active brick,
// brick_layout.glsl) whose scanned triangle offset is <= t, in the row's first cell whose running
// count passes the rest. A vertex index is the scanned offset of the segment holding the edge's
// start point (in the brick that owns that point, maybe a neighbour), plus the vertices before
// the point in its row, plus the edge's rank among the point's crossing edges: the global
// edge-key order of the CPU reference.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Masks { uint masks[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cases { uint cases[]; };
layout(std430, set = 0, binding = 2) readonly buffer Edges { uvec4 edges[]; };
layout(std430, set = 0, binding = 3) readonly buffer VertexSegments { uint vertexSegments[]; };  // scanned
layout(std430, set = 0, binding = 4) readonly buffer TriangleSegments { uint triangleSegments[]; };  // scanned
layout(std430, set = 0, binding = 5) readonly buffer TriangleRows { uvec2 triangleRows[]; };
layout(std430, set = 0, binding = 6) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Indices { uint indices[]; };
#define BRICK_SCAN_BINDING 8
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;   // cells per axis, w = log2(B)
  uvec4 bricks;  // bricks per axis, w = active bricks of this batch
  uint segments;    // cell rows in the scan
  uint triangles;   // the batch's triangle count
  uint activeBase;  // the batch's first active brick (brick_rows.comp)
  uint vertexBase;  // vertices of the batches before this one
} pc;

void main() {
  uint t = linearInvocation();
  if (t >= pc.triangles) return;
  uint lo = 0u, hi = pc.segments;  // triangleSegments[lo] <= t < triangleSegments[hi] (or the end)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (triangleSegments[mid] <= t) lo = mid; else hi = mid;
  }
  uvec2 row = triangleRows[lo];
  uint B = 1u << pc.cells.w, R = B + 1u;
  uint lz = divideSmall(row.y, R), ly = row.y - lz * R;
  uvec3 g0 = unpackBrick(bricks[row.x]) << pc.cells.w;
  uint at = row.x * R * R + row.y;
  uint m = masks[at], my = masks[at + 1u], mz = masks[at + R], myz = masks[at + R + 1u];
  uint rest = t - triangleSegments[lo];
  uint x = 0u, config = 0u;
  for (;;) {  // the cell holding the rest-th triangle of the row
    config = ((m >> x) & 3u) | (((my >> x) & 3u) << 2) | (((mz >> x) & 3u) << 4) | (((myz >> x) & 3u) << 6);
    uint n = cases[config * 20u];
    if (rest < n || x + 1u >= B) break;
    rest -= n;
    ++x;
  }
  uvec3 lastBrick = pc.bricks.xyz - 1u;
  for (uint i = 0u; i < 3u; ++i) {
    uint e = cases[config * 20u + 1u + rest * 3u + i];
    uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
    uvec3 start = axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u));
    // The edge's start point and the brick that owns it (brick_layout.glsl).
    uvec3 g = g0 + uvec3(x, ly, lz) + start;
    uvec3 owner = min(g >> pc.cells.w, lastBrick);
    uvec3 local = g - (owner << pc.cells.w);
    // The owner lies in the batch: its brick layer is this one or the next, which the batch
    // holds too (its vertices go to the next batch, but its segments are scanned here).
    uint ownerNumber = brickScan[(owner.z * pc.bricks.y + owner.y) * pc.bricks.x + owner.x] - pc.activeBase;
    uvec3 oe = edges[ownerNumber * R * R + local.z * R + local.y].xyz;
    uint bits = ((oe.x >> local.x) & 1u) | (((oe.y >> local.x) & 1u) << 1) | (((oe.z >> local.x) & 1u) << 2);
    uint rank = bitCount(bits & ((1u << axis) - 1u));
    uint segment = segmentPosition(pc.activeBase + ownerNumber, owner, pc.bricks.xyz, local.y, local.z, R) -
                   pc.activeBase * R * R;
    indices[t * 3u + i] = pc.vertexBase + vertexSegments[segment] + rowVerticesBefore(oe, local.x) + rank;
  }
}
