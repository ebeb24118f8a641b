#version 450
// Sparse extraction, tiled vertex pass, step 3 of 3: one invocation per vertex of the batch puts
// its number in its tile's run of the lists (brick_vertex_tile_args.comp). The order within a run
// follows the atomics and may differ between runs; it does not matter: the tile's vertex kernel
// writes each vertex to its own slot, computed lane by lane with no cross-lane operation, so the
// mesh is the same bytes whatever vertices share a vector.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer VertexSources { uvec2 vertexSources[]; };
layout(std430, set = 0, binding = 1) readonly buffer BrickTiles { uint brickTiles[]; };  // per batch brick
layout(std430, set = 0, binding = 2) buffer Counters { uint counters[]; };  // [tiles + tile]: cursors
layout(std430, set = 0, binding = 3) writeonly buffer TileVertices { uint tileVertices[]; };

layout(push_constant) uniform Push {
  uint vertices;  // the batch's
  uint tiles;
} pc;

void main() {
  uint v = linearInvocation();
  if (v >= pc.vertices) return;
  uint t = brickTiles[vertexSources[v].x];
  tileVertices[atomicAdd(counters[pc.tiles + t], 1u)] = v;
}
