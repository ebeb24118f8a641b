// The sparse vertex kernels' body (brick_vertices.comp, brick_vertices_direct.comp, and their
// per-tile forms with BRICK_VERTICES_TILED: a lane per entry of one tile's vertex list; with
// EVAL_TAPES, brick_vertices_direct_tapes.comp: each vertex's gradient from its brick's tape; with
// both, brick_vertices_direct_tapes_uniform.comp: a window of bricks' tapes, its vertex list).
#ifndef BLOBVK_BRICK_VERTICES_BODY_GLSL
#define BLOBVK_BRICK_VERTICES_BODY_GLSL
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"
#include "brick_layout.glsl"

layout(std430, set = 0, binding = 5) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 6) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 7) readonly buffer VertexSources { uvec2 vertexSources[]; };  // brick_sources.comp
layout(std430, set = 0, binding = 8) writeonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = 9) writeonly buffer Normals { float normals[]; };
layout(std430, set = 0, binding = 10) writeonly buffer Colours { float colours[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Keys { uvec2 keys[]; };
#ifdef EVAL_TAPES
// Per batch brick, its vertex tape's first instruction and end (vk/extract/brick_tapes.h,
// TapeUse::Vertex), the tapes bound in place of the program's code (in its window's block).
#ifdef BRICK_VERTICES_TILED
layout(std430, set = 0, binding = 14) readonly buffer BrickTapes { uvec2 brickTapes[]; };
#else
layout(std430, set = 0, binding = 12) readonly buffer BrickTapes { uvec2 brickTapes[]; };
#endif
uint evalTapeEnd = 0u;
#define EVAL_CODE_END evalTapeEnd
#endif
#ifdef BRICK_VERTICES_TILED
layout(std430, set = 0, binding = 12) readonly buffer TileVertices { uint tileVertices[]; };  // brick_vertex_tile_lists
layout(std430, set = 0, binding = 13) readonly buffer TileArgs { uint tileArgs[]; };  // brick_vertex_tile_args
#endif

layout(push_constant) uniform Push {
  vec4 originCell;
  uint codeLength;
  uint refineSteps;
  uint attributes;  // bit 0 normals, bit 1 colours
  float normalStep;
  uint log2B;
  uint vertices;    // the batch's vertex count
  uint nx, ny;      // grid points per axis (edge keys)
  uint tailBase;    // the samples' tail (brick_layout.glsl, fieldIndex)
#ifdef BRICK_VERTICES_TILED
  uint tile;        // its count and first list entry: tileArgs[tile * 8 + 3], [tile * 8 + 4] (a window's, with EVAL_TAPES)
#endif
} pc;

#include "edge_vertex.glsl"

void main() {
#ifdef BRICK_VERTICES_TILED
  uint i = linearInvocation();
  if (i >= tileArgs[pc.tile * 8u + 3u]) return;
  uint v = tileVertices[tileArgs[pc.tile * 8u + 4u] + i];
#else
  uint v = linearInvocation();
  if (v >= pc.vertices) return;
#endif
  uvec2 source = vertexSources[v];
#ifdef EVAL_TAPES
  // Lanes may hold different bricks' tapes: the gradient interpreter runs each lane's own
  // (its instruction counter is per lane, eval_gradient.glsl).
  uvec2 tape = brickTapes[source.x];
  evalTapeBegin = tape.x;
  evalTapeEnd = tape.y;
#endif
  uint R = (1u << pc.log2B) + 1u;
  uint r = source.y >> 7, x0 = (source.y >> 2) & 31u, axis = source.y & 3u;
  uint lz = divideSmall(r, R), ly = r - lz * R;
  uvec3 g = (unpackBrick(bricks[source.x], bricksOfPoints(uvec2(pc.nx, pc.ny), pc.log2B)) << pc.log2B) + uvec3(x0, ly, lz);
  uint row = source.x * R * R + r;
  uint fa = fieldIndex(row, x0, pc.log2B, pc.tailBase);
  uint fb = axis == 0u ? fieldIndex(row, x0 + 1u, pc.log2B, pc.tailBase)
                       : fieldIndex(row + (axis == 1u ? 1u : R), x0, pc.log2B, pc.tailBase);
  emitEdgeVertex(v, g, axis, field[fa], field[fb]);
  // Key = ((z * ny + y) * nx + x) * 3 + axis in 64 bits.
  uint khi, klo, carry;
  umulExtended(g.z * pc.ny + g.y, pc.nx, khi, klo);
  klo = uaddCarry(klo, g.x, carry);
  khi += carry;
  uint h3, l3;
  umulExtended(klo, 3u, h3, l3);
  khi = khi * 3u + h3;
  l3 = uaddCarry(l3, axis, carry);
  keys[v] = uvec2(l3, khi + carry);
}

#endif
