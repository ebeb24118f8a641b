#version 450
// One invocation per vertex of a slab (dispatched indirectly from the draw_args pass): the vertex
// of slab-local index v belongs to the last owned point whose scanned offset is <= v (a binary
// search over the exclusive scan), on its (v - offset)-th crossing upper edge, so vertices stay
// in global edge-key order. The work of a vertex: vertex_emit.glsl.
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

#include "vertex_emit.glsl"

void main() {
  uint v = linearInvocation();
  if (v >= args[5] - pc.vertexBase) return;
  uint lo = 0u, hi = pc.ownedPoints;  // vertexOffsets[lo] <= v < vertexOffsets[hi] (or the end)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (vertexOffsets[mid] <= v) lo = mid; else hi = mid;
  }
  emitVertex(v, lo);
}
