#version 450
// Sparse extraction, tiled vertex pass, step 1 of 3: one invocation per vertex of the batch counts
// it in its brick's field tile (vk/extract/brick_tiles.h). The tile of each batch brick comes from
// the host (orderBricksByTile); a vertex's brick from brick_sources.comp.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer VertexSources { uvec2 vertexSources[]; };
layout(std430, set = 0, binding = 1) readonly buffer BrickTiles { uint brickTiles[]; };  // per batch brick
layout(std430, set = 0, binding = 2) buffer Counters { uint counters[]; };  // [tile]: vertices, zeroed before

layout(push_constant) uniform Push {
  uint vertices;  // the batch's
} pc;

void main() {
  uint v = linearInvocation();
  if (v >= pc.vertices) return;
  atomicAdd(counters[brickTiles[vertexSources[v].x]], 1u);
}
