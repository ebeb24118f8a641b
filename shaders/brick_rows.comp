#version 450
// Sparse extraction, pass 5: from the inside masks of brick_field.comp, each row of points of an
// active brick (brick_layout.glsl) stores its vertex count (its owned crossing upper edges,
// ownedRowEdges) at its segment position and, for local y, z < B, the triangle count of its row
// of cells (case table). One invocation per column of rows (brick a, local y: invocation
// a * R + y), walking local z (brick_layout.glsl, MaskColumn). Every per-brick array holds the
// batch's (vk/extract/sparse_batches.cpp: bricks run in batches of whole brick layers), segment
// positions are the batch's share of the global order (`segments`, brick_layout.glsl's segmentOf).
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer Segments { uvec4 segments[]; };  // brick_neighbours.comp
layout(std430, set = 0, binding = 3) writeonly buffer VertexSegments { uint vertexSegments[]; };
layout(std430, set = 0, binding = 4) writeonly buffer TriangleSegments { uint triangleSegments[]; };
#define MASKS_BINDING 0
#define CASES_BINDING 2
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;   // cells per axis, w = log2(B)
  uvec4 bricks;  // bricks per axis, w = active bricks of this batch
} pc;

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u;
  uint column = linearInvocation();
  if (column >= pc.bricks.w * R) return;
  uint a = column / R, ly = column - a * R;
  uvec4 seg = segments[a];
  uvec3 g0 = unpackBrick(seg.x, pc.bricks.xy) << pc.cells.w;
  uint gy = g0.y + ly;
  uint xEnd = min(pc.cells.x - g0.x, B);
  uint rowBase = a * R * R;
  MaskColumn c = firstMaskStep(rowBase, ly, R);
  for (uint lz = 0u; lz < R; ++lz) {
    if (lz > 0u) nextMaskStep(c, rowBase, ly, lz - 1u, R);
    uvec3 e = ownedRowEdges(c.m, c.my, c.mz, pc.cells.xyz, g0, pc.cells.w, ly, lz);
    vertexSegments[segmentOf(seg, seg.y, R, ly, lz)] = bitCount(e.x) + bitCount(e.y) + bitCount(e.z);
    if (ly < B && lz < B) {
      uint triangles = 0u;
      if (gy < pc.cells.y && g0.z + lz < pc.cells.z) {
        // Only the cells with corners on both sides (brick_sources.comp): a surface crosses a few
        // of a row's B cells, and a loop runs as long as its longest lane.
        for (uint cells = mixedCells(c) & ((1u << xEnd) - 1u); cells != 0u; cells &= cells - 1u) {
          uint x = findLSB(cells);
          triangles += cases[cellConfig(c, x)].x;
        }
      }
      triangleSegments[segmentOf(seg, seg.z, B, ly, lz)] = triangles;
    }
  }
}
