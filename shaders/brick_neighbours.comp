#version 450
// Sparse extraction: for each brick of the batch, the batch numbers of itself and of its seven
// upper neighbours (+x, +y, +x+y, +z, ... : entry k = x | y << 1 | z << 2), ~0 where that
// neighbour is outside the grid or inactive, found by binary search in x among its row's active
// bricks. A triangle's vertex on the brick's upper face belongs to the neighbour there
// (brick_layout.glsl); brick_triangles.comp finds it here in one load. Such a neighbour is active whenever the edge crosses: the edge lies
// in its box, whose samples the classification bounds. And each brick's segmentOf record
// (brick_layout.glsl), so the per-row kernels find their rows' places in one load instead of four
// of the row starts each.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Neighbours { uint neighbours[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Segments { uvec4 segments[]; };
#define ROW_STARTS_BINDING 3
#include "brick_layout.glsl"
layout(std430, set = 0, binding = 4) readonly buffer WindowBricks { uint windowBricks[]; };  // the window's list

layout(push_constant) uniform Push {
  uvec4 bricks;     // bricks per axis, w = active bricks of this batch
  uint activeBase;  // the batch's first active brick, counted from the window's
  uint log2B;
  uint firstLayer;  // the window's first brick layer (row starts and list begin there)
} pc;

void main() {
  uint a = linearInvocation();
  if (a >= pc.bricks.w) return;
  uint coords = bricks[a];
  uvec3 b = unpackBrick(coords, pc.bricks.xy);
  for (uint k = 0u; k < 8u; ++k) {
    uvec3 n = b + uvec3(k & 1u, (k >> 1) & 1u, k >> 2);
    uint number = 0xffffffffu;
    if (all(lessThan(n, pc.bricks.xyz))) {
      uint row = (n.z - pc.firstLayer) * pc.bricks.y + n.y;
      uint lo = rowStarts[row], end = rowStarts[row + 1u], hi = end;
      while (lo < hi) {  // the first of the row's bricks with x >= n.x
        uint mid = (lo + hi) >> 1;
        if (unpackBrick(windowBricks[mid], pc.bricks.xy).x < n.x) lo = mid + 1u;
        else hi = mid;
      }
      if (lo < end && unpackBrick(windowBricks[lo], pc.bricks.xy).x == n.x) number = lo - pc.activeBase;
    }
    neighbours[a * 8u + k] = number;
  }
  segments[a] = brickSegments(pc.activeBase + a, coords, b, pc.bricks.xyz, pc.activeBase, pc.log2B, pc.firstLayer);
}
