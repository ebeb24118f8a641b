#version 450
// Sparse extraction, after brick_compact: the number of each brick row's first active brick,
// rowStarts[r] = brickScan[r * bricks.x] for rows r = (z - firstLayer) * bricks.y + y of the scan's
// window, and one more (the window's active count). The batches read these and the active-brick
// list, not the scan (one word per brick of the grid), which the next window's classification
// overwrites (vk::ScanWindow).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer BrickScan { uint brickScan[]; };
layout(std430, set = 0, binding = 1) writeonly buffer RowStarts { uint rowStarts[]; };

layout(push_constant) uniform Push {
  uint bricksX;  // bricks along x: a row's length in the scan
  uint rows;     // rows of the window (the last word is row `rows`)
} pc;

void main() {
  uint r = linearInvocation();
  if (r > pc.rows) return;
  rowStarts[r] = brickScan[r * pc.bricksX];
}
