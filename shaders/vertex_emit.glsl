// Included by vertices.comp and vertices_tiled.comp after eval_program.glsl and common.glsl:
// their shared bindings, push constants and the work of one vertex of a slab (the vertex itself:
// edge_vertex.glsl).
#ifndef BLOBVK_VERTEX_EMIT_GLSL
#define BLOBVK_VERTEX_EMIT_GLSL

layout(std430, set = 0, binding = 5) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 6) readonly buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = 7) readonly buffer VertexOffsets { uint vertexOffsets[]; };
layout(std430, set = 0, binding = 8) writeonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = 9) writeonly buffer Normals { float normals[]; };
layout(std430, set = 0, binding = 10) writeonly buffer Colours { float colours[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 12) readonly buffer Args { uint args[]; };  // draw_args.comp

layout(push_constant) uniform Push {
  vec4 originCell;
  uint nx, ny;
  uint ownedPoints;  // owned points of the slab
  uint k0;
  uint codeLength;
  uint refineSteps;
  uint attributes;   // bit 0 normals, bit 1 colours
  float normalStep;  // central-difference step h
  uint vertexBase;   // vertices of the slabs before this one
  // vertices_tiled.comp only: the tile's points of this slab (x i0 .. i0 + tileNx - 1,
  // y j0 .. j0 + tileNy - 1, slab-local layers layer0 ..), its rows in the row scan and its
  // slot in the tile arguments.
  uint tileI0, tileNx, tileJ0, tileNy, tileLayer0, rowBase, rows, tileIndex;
  uint vertexCapacity;  // vertices the output buffers hold (slab-local); later ones are dropped
} pc;

#include "edge_vertex.glsl"

// Vertex v of the slab (slab-local), on a crossing upper edge of point idx (slab-local).
void emitVertex(uint v, uint idx) {
  // Beyond the caller's buffers: emit_limits.comp has flagged the overflow.
  if (v >= pc.vertexCapacity) return;
  uint bits = flags[idx];
  uint rank = v - vertexOffsets[idx];
  uint axis = findLSB(bits);
  if (rank > 0u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  if (rank > 1u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  uint i = idx % pc.nx, j = (idx / pc.nx) % pc.ny, k = pc.k0 + idx / (pc.nx * pc.ny);
  emitEdgeVertex(v, uvec3(i, j, k), axis, field[idx],
                 field[idx + (axis == 0u ? 1u : (axis == 1u ? pc.nx : pc.nx * pc.ny))]);
  keys[v] = idx * 3u + axis;
}

#endif
