#version 450
// The vertex pass of one field tile (vk/extract/slab_polygonizer.cpp), so each tile's vertices run the
// evaluator pruned to the tile (vk/eval/field_tiles.h), as its field did. One invocation per vertex of
// the tile in this slab (dispatched indirectly from tile_args.comp): the tile's rows (x runs of
// its points) have their vertex counts scanned in rowScan (tile_rows.comp + a scan); invocation v
// finds its row by binary search there, then its point within the row by binary search over the
// slab's vertex scan, exactly as vertices.comp does over the whole slab. Outputs go to the
// vertex's slab-wide slot, so the mesh is the one vertices.comp writes.
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

#include "vertex_emit.glsl"

layout(std430, set = 0, binding = 13) readonly buffer RowScan { uint rowScan[]; };

void main() {
  uint v = linearInvocation();
  if (v >= args[pc.tileIndex * 4u + 3u]) return;
  uint target = rowScan[pc.rowBase] + v;
  uint lo = 0u, hi = pc.rows;  // the last row whose scanned start is <= target
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (rowScan[pc.rowBase + mid] <= target) lo = mid; else hi = mid;
  }
  uint row = lo;
  uint rowStart = ((pc.tileLayer0 + row / pc.tileNy) * pc.ny + pc.tileJ0 + row % pc.tileNy) * pc.nx + pc.tileI0;
  uint vs = vertexOffsets[rowStart] + (target - rowScan[pc.rowBase + row]);
  uint a = rowStart, b = rowStart + pc.tileNx;  // vertexOffsets[a] <= vs < vertexOffsets[b]
  while (b - a > 1u) {
    uint mid = (a + b) / 2u;
    if (vertexOffsets[mid] <= vs) a = mid; else b = mid;
  }
  emitVertex(vs, a);
}
