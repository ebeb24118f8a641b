#version 450
// Sparse extraction, pass 2 (after the exclusive scan of brick_classify's flags): the list of
// active bricks, each at its number brickScan[brick], as packed coordinates (brick_layout.glsl, packBrick).
// Written in place of an append, so the list is in (bz, by, bx) order whatever the scheduling.
#extension GL_GOOGLE_include_directive : require
#include "brick_layout.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(std430, set = 0, binding = 0) readonly buffer BrickScan { uint brickScan[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Bricks { uint bricks[]; };

layout(push_constant) uniform Push {
  uvec4 bricks;  // bricks per axis, w = the first brick layer listed
  uint endLayer; // the end of the brick layers listed
  uint scanBase; // the brick (linear index) whose flag is brickScan[0] (vk::ScanWindow)
} pc;

void main() {
  uvec3 b = gl_GlobalInvocationID + uvec3(0u, 0u, pc.bricks.w);
  if (any(greaterThanEqual(b, uvec3(pc.bricks.xy, pc.endLayer)))) return;
  uint brick = (b.z * pc.bricks.y + b.y) * pc.bricks.x + b.x - pc.scanBase;
  uint number = brickScan[brick];
  if (brickScan[brick + 1u] != number) bricks[number] = packBrick(b, pc.bricks.xy);
}
