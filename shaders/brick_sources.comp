#version 450
// Sparse extraction, pass 6 (after the scans): per row of points of a brick of the batch
// (brick_layout.glsl), it gives each point of the row with a crossing upper edge its *point
// word* (first vertex << 3 | the point's crossing edges, bit i: the +i edge), the vertex counted
// from the batch's first segment (the row's scanned segment plus the vertices before the point),
// so the triangle pass finds a corner's vertex with one load; for a brick the batch emits, it
// writes where each of the row's vertices (brick, row, point, axis) and, for local y, z < B,
// where each triangle of its row of cells comes from (brick, configuration, its k-th triangle,
// cell, the brick's upper faces that belong to neighbours), in the global order. The vertex and
// triangle passes then run one lane per output with no search. Point words of points without a
// crossing edge are never written nor read. One invocation per column of rows (brick a, local y:
// invocation a * R + y), walking local z, as brick_rows.comp: the row's crossing edges come from
// the same masks again (three words kept per row would cost more stores and loads than they save).
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer Segments { uvec4 segments[]; };  // brick_neighbours.comp
layout(std430, set = 0, binding = 3) readonly buffer VertexSegments { uint vertexSegments[]; };      // scanned
layout(std430, set = 0, binding = 4) readonly buffer TriangleSegments { uint triangleSegments[]; };  // scanned
// Vertex v: (brick, row << 7 | x << 2 | axis). Triangle t: (brick, configuration | k << 8 | x << 11 |
// cell row (y + z * B) << 15 | faces << 23), faces bit i: the brick is not the grid's last on axis i.
layout(std430, set = 0, binding = 5) writeonly buffer VertexSources { uvec2 vertexSources[]; };
layout(std430, set = 0, binding = 6) writeonly buffer TriangleSources { uvec2 triangleSources[]; };
layout(std430, set = 0, binding = 7) writeonly buffer PointWords { uint pointWords[]; };  // R^3 per brick
#define MASKS_BINDING 0
#define CASES_BINDING 2
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;      // cells per axis, w = log2(B)
  uvec4 bricks;     // bricks per axis, w = bricks of this batch (those it emits and the next layer's)
  uint ownActive;   // bricks the batch emits
} pc;

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u;
  uint column = linearInvocation();
  if (column >= pc.bricks.w * R) return;
  uint a = column / R, ly = column - a * R;
  uvec4 seg = segments[a];
  uvec3 b = unpackBrick(seg.x, pc.bricks.xy);
  uvec3 g0 = b << pc.cells.w;
  // The next layer's bricks (a >= ownActive) get their point words alone: this batch's triangles
  // of its last layer use the vertices on their lower faces.
  bool own = a < pc.ownActive;
  uint xEnd = min(pc.cells.x - g0.x, B);
  uint faces = (b.x + 1u < pc.bricks.x ? 1u : 0u) | (b.y + 1u < pc.bricks.y ? 2u : 0u) | (b.z + 1u < pc.bricks.z ? 4u : 0u);
  uint rowBase = a * R * R;
  MaskColumn c = firstMaskStep(rowBase, ly, R);
  for (uint lz = 0u; lz < R; ++lz) {
    if (lz > 0u) nextMaskStep(c, rowBase, ly, lz - 1u, R);
    uint r = lz * R + ly, row = rowBase + r;
    uvec3 e = ownedRowEdges(c.m, c.my, c.mz, pc.cells.xyz, g0, pc.cells.w, ly, lz);
    uint v = vertexSegments[segmentOf(seg, seg.y, R, ly, lz)];
    // One loop over the row's vertices, not one over its points and one over each point's
    // edges: llvmpipe runs a loop's body at least once, as long as its longest lane, and each
    // store in it as a loop over the lanes.
    uint pending = e.x | e.y | e.z;  // points whose vertices are still to come
    uint count = bitCount(e.x) + bitCount(e.y) + bitCount(e.z);
    uint x = 0u, bits = 0u;
    for (uint i = 0u; i < count; ++i) {
      if (bits == 0u) {  // the next point: its word, then its vertices in axis order
        x = findLSB(pending);
        pending &= pending - 1u;
        bits = ((e.x >> x) & 1u) | (((e.y >> x) & 1u) << 1) | (((e.z >> x) & 1u) << 2);
        pointWords[row * R + x] = (v << 3) | bits;
      }
      if (own) vertexSources[v] = uvec2(a, (r << 7) | (x << 2) | uint(findLSB(bits)));
      ++v;
      bits &= bits - 1u;
    }
    if (!own || ly >= B || lz >= B || g0.y + ly >= pc.cells.y || g0.z + lz >= pc.cells.z) continue;
    uint t = triangleSegments[segmentOf(seg, seg.z, B, ly, lz)];
    uint tag = ((ly + (lz << pc.cells.w)) << 15) | (faces << 23);
    // One loop over the row's triangles, as over its vertices: the next mixed cell is taken in a
    // branch, not an inner loop, whose loop overhead llvmpipe paid at every triangle (sources pass
    // about a tenth shorter on tower and eggshell at 256 and 512 cells).
    uint cells = mixedCells(c) & ((1u << xEnd) - 1u);
    uint cx = 0u, config = 0u, k = 0u, n = 0u;
    for (;;) {
      if (k == n) {  // the next mixed cell: every configuration but 0 and 255 has a triangle
        if (cells == 0u) break;
        cx = findLSB(cells);
        cells &= cells - 1u;
        config = cellConfig(c, cx);
        n = cases[config].x;
        k = 0u;
      }
      triangleSources[t++] = uvec2(a, config | (k << 8) | (cx << 11) | tag);
      ++k;
    }
  }
}
