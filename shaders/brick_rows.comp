#version 450
// Sparse extraction, pass 4: per row of an active brick (brick_layout.glsl), one invocation:
//  - the row of points (local y, z < R) it owns: each point's crossing upper edges (+x bit 0,
//    +y bit 1, +z bit 2; inside is f >= iso, as in the CPU reference) and the vertices before it
//    in the row, packed as flags | prefix << 3; the row's vertex count at its segment position
//    (and the segment's brick and row, for the vertex pass's search). Points the row does not own
//    get the row's total as prefix, so the prefixes stay sorted.
//  - for local y, z < B, the row of cells: its triangle count (case table) at its segment position.
// Invocation x is the row (y + z * R), y + z * (groups in y) the active brick.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 1) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 2) readonly buffer Cases { uint cases[]; };  // 20 per config
layout(std430, set = 0, binding = 3) writeonly buffer Points { uint points[]; };
layout(std430, set = 0, binding = 4) writeonly buffer VertexSegments { uint vertexSegments[]; };
layout(std430, set = 0, binding = 5) writeonly buffer SegmentRows { uvec2 segmentRows[]; };
layout(std430, set = 0, binding = 6) writeonly buffer TriangleSegments { uint triangleSegments[]; };
#define BRICK_SCAN_BINDING 7
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;   // cells per axis, w = log2(B)
  uvec4 bricks;  // bricks per axis, w = active bricks
} pc;

bool inside(uint idx) { return field[idx] >= ISO_VALUE; }

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u, P = R * R * R;
  uint r = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || a >= pc.bricks.w) return;
  uint lz = divideSmall(r, R), ly = r - lz * R;
  uvec3 b = unpackBrick(bricks[a]);
  uvec3 g0 = b << pc.cells.w;
  uint gy = g0.y + ly, gz = g0.z + lz;
  uint base = a * P + r * R;
  // The row's points: local x < B, and local x = B on the grid's last point of the axis.
  bool ownsRow = (ly < B || gy == pc.cells.y) && (lz < B || gz == pc.cells.z) && gy <= pc.cells.y && gz <= pc.cells.z;
  uint count = 0u;
  for (uint lx = 0u; lx < R; ++lx) {
    uint gx = g0.x + lx;
    uint word = 0u;
    if (ownsRow && (lx < B || gx == pc.cells.x) && gx <= pc.cells.x) {
      uint idx = base + lx;
      bool in_ = inside(idx);
      uint bits = 0u;
      if (gx < pc.cells.x && inside(idx + 1u) != in_) bits |= 1u;
      if (gy < pc.cells.y && inside(idx + R) != in_) bits |= 2u;
      if (gz < pc.cells.z && inside(idx + R * R) != in_) bits |= 4u;
      word = bits | (count << 3);
      count += bitCount(bits);
    } else {
      word = count << 3;
    }
    points[base + lx] = word;
  }
  uint s = segmentPosition(a, b, pc.bricks.xyz, ly, lz, R);
  vertexSegments[s] = count;
  segmentRows[s] = uvec2(a, r);
  if (ly < B && lz < B) {
    uint triangles = 0u;
    if (gy < pc.cells.y && gz < pc.cells.z) {
      for (uint lx = 0u; lx < B && g0.x + lx < pc.cells.x; ++lx) {
        uint p = base + lx, config = 0u;
        for (uint corner = 0u; corner < 8u; ++corner) {
          uint q = p + (corner & 1u) + R * ((corner >> 1) & 1u) + R * R * ((corner >> 2) & 1u);
          if (inside(q)) config |= 1u << corner;
        }
        triangles += cases[config * 20u];
      }
    }
    triangleSegments[segmentPosition(a, b, pc.bricks.xyz, ly, lz, B)] = triangles;
  }
}
