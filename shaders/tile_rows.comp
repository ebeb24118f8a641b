#version 450
// Per row of one field tile in a slab (an x run of the tile's points at one y and layer): how
// many vertices its points own, from the slab's exclusive vertex scan. The rows of all tiles are
// then scanned together (vertices_tiled.comp).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer VertexOffsets { uint vertexOffsets[]; };
layout(std430, set = 0, binding = 1) readonly buffer Totals { uint totals[]; };  // [0] the slab's vertices
layout(std430, set = 0, binding = 2) writeonly buffer RowCounts { uint rowCounts[]; };

layout(push_constant) uniform Push {
  uint nx, ny;
  uint tileI0, tileNx, tileJ0, tileNy, tileLayer0;
  uint rows, rowBase;
  uint classified;  // values in the vertex scan (its total is totals[0])
} pc;

void main() {
  uint r = linearInvocation();
  if (r >= pc.rows) return;
  uint start = ((pc.tileLayer0 + r / pc.tileNy) * pc.ny + pc.tileJ0 + r % pc.tileNy) * pc.nx + pc.tileI0;
  uint end = start + pc.tileNx;
  uint endOffset = end < pc.classified ? vertexOffsets[end] : totals[0];
  rowCounts[pc.rowBase + r] = endOffset - vertexOffsets[start];
}
