#version 450
// Sparse extraction, pass 5: per row of points of an active brick (brick_layout.glsl), one
// invocation finds, from the inside masks of brick_field.comp, the crossing upper edges of the
// points the row owns (bit x of edges.x, .y, .z: the +x, +y, +z edge of point x) and stores the
// row's vertex count at its segment position; for local y, z < B, the triangle count of the row
// of cells likewise. Invocation x is the row (y + z * R), y + z * (groups in y) the active brick
// of the batch (vk/extract/sparse_batches.cpp: bricks run in batches of whole brick layers;
// every per-brick array holds the batch's, segment positions are the batch's share of the global
// order: `segments`, brick_layout.glsl's segmentOf). edges.w is left for brick_sources.comp (the row's first vertex).
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Masks { uint masks[]; };
layout(std430, set = 0, binding = 1) readonly buffer Segments { uvec4 segments[]; };  // brick_neighbours.comp
layout(std430, set = 0, binding = 3) writeonly buffer Edges { uvec4 edges[]; };
layout(std430, set = 0, binding = 4) writeonly buffer VertexSegments { uint vertexSegments[]; };
layout(std430, set = 0, binding = 5) writeonly buffer TriangleSegments { uint triangleSegments[]; };
#define CASES_BINDING 2
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;   // cells per axis, w = log2(B)
  uvec4 bricks;  // bricks per axis, w = active bricks of this batch
} pc;

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u;
  uint r = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || a >= pc.bricks.w) return;
  uint lz = divideSmall(r, R), ly = r - lz * R;
  uvec4 seg = segments[a];
  uvec3 b = unpackBrick(seg.x);
  uvec3 g0 = b << pc.cells.w;
  uint gy = g0.y + ly, gz = g0.z + lz;
  uint row = a * R * R + r;
  uint m = masks[row];
  uint my = ly + 1u < R ? masks[row + 1u] : m;
  uint mz = lz + 1u < R ? masks[row + R] : m;
  // Points the row owns: local x < B, and x = B on the grid's last point of the axis; none
  // past the grid's end. Rows likewise in y and z.
  uint xEnd = min(pc.cells.x - g0.x, B);  // points x < xEnd have a +x edge in the grid
  uint owned = g0.x + B == pc.cells.x ? (2u << B) - 1u : (1u << min(pc.cells.x - g0.x + 1u, B)) - 1u;
  bool ownsRow = (ly < B || gy == pc.cells.y) && (lz < B || gz == pc.cells.z) && gy <= pc.cells.y && gz <= pc.cells.z;
  uvec3 e = uvec3(0u);
  if (ownsRow) {
    e.x = (m ^ (m >> 1)) & ((1u << xEnd) - 1u);
    e.y = gy < pc.cells.y ? (m ^ my) & owned : 0u;
    e.z = gz < pc.cells.z ? (m ^ mz) & owned : 0u;
  }
  edges[row].xyz = e;
  uint s = segmentOf(seg, seg.y, R, ly, lz);
  vertexSegments[s] = bitCount(e.x) + bitCount(e.y) + bitCount(e.z);
  if (ly < B && lz < B) {
    uint triangles = 0u;
    if (gy < pc.cells.y && gz < pc.cells.z) {
      uint myz = masks[row + R + 1u];
      for (uint x = 0u; x < xEnd; ++x) {
        uint config = ((m >> x) & 3u) | (((my >> x) & 3u) << 2) | (((mz >> x) & 3u) << 4) | (((myz >> x) & 3u) << 6);
        triangles += cases[config].x;
      }
    }
    uint t = segmentOf(seg, seg.z, B, ly, lz);
    triangleSegments[t] = triangles;
  }
}
