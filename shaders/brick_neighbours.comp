#version 450
// Sparse extraction: for each brick of the batch, the batch numbers of itself and of its seven
// upper neighbours (+x, +y, +x+y, +z, ... : entry k = x | y << 1 | z << 2), ~0 where that
// neighbour is outside the grid or inactive. A triangle's vertex on the brick's upper face belongs
// to the neighbour there (brick_layout.glsl); brick_triangles.comp finds it here in one load
// instead of the brick scan. Such a neighbour is active whenever the edge crosses: the edge lies
// in its box, whose samples the classification bounds. And each brick's segmentOf record
// (brick_layout.glsl), so the per-row kernels find their rows' places in one load instead of four
// of the brick scan each.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Neighbours { uint neighbours[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Segments { uvec4 segments[]; };
#define BRICK_SCAN_BINDING 3
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 bricks;     // bricks per axis, w = active bricks of this batch
  uint activeBase;  // the batch's first active brick, counted from the scan window's
  uint log2B;
  uint scanBase;    // the brick (linear index) whose flag is brickScan[0]: the window's first
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
      uint linear = (n.z * pc.bricks.y + n.y) * pc.bricks.x + n.x;
      uint first = brickScan[linear - pc.scanBase];
      if (brickScan[linear - pc.scanBase + 1u] > first) number = first - pc.activeBase;
    }
    neighbours[a * 8u + k] = number;
  }
  segments[a] = brickSegments(pc.activeBase + a, coords, b, pc.bricks.xyz, pc.activeBase, pc.log2B, pc.scanBase);
}
