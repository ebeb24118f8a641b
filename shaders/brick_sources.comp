#version 450
// Sparse extraction, pass 6 (after the scans): per row of points of a brick of the batch
// (brick_layout.glsl), one invocation gives each point of the row with a crossing upper edge its
// *point word* (first vertex << 3 | the point's crossing edges, bit i: the +i edge), the vertex
// counted from the batch's first segment (the row's scanned segment plus the vertices before the
// point), so the triangle pass finds a corner's vertex with one load; for a brick the batch emits,
// it writes where each of the row's vertices (brick, row, point, axis) and, for local y, z < B,
// where each triangle of its row of cells comes from (brick, configuration, its k-th triangle,
// cell, the brick's upper faces that belong to neighbours), in the global order. The vertex and
// triangle passes then run one lane per output with no search. Invocation x is the row
// (y + z * R), y + z * (groups in y) the brick of the batch. Point words of points without a
// crossing edge are never written nor read.
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Masks { uint masks[]; };
layout(std430, set = 0, binding = 1) readonly buffer Segments { uvec4 segments[]; };  // brick_neighbours.comp
layout(std430, set = 0, binding = 3) readonly buffer Edges { uvec4 edges[]; };
layout(std430, set = 0, binding = 4) readonly buffer VertexSegments { uint vertexSegments[]; };      // scanned
layout(std430, set = 0, binding = 5) readonly buffer TriangleSegments { uint triangleSegments[]; };  // scanned
// Vertex v: (brick, row << 7 | x << 2 | axis). Triangle t: (brick, configuration | k << 8 | x << 11 |
// cell row (y + z * B) << 15 | faces << 23), faces bit i: the brick is not the grid's last on axis i.
layout(std430, set = 0, binding = 6) writeonly buffer VertexSources { uvec2 vertexSources[]; };
layout(std430, set = 0, binding = 7) writeonly buffer TriangleSources { uvec2 triangleSources[]; };
layout(std430, set = 0, binding = 8) writeonly buffer PointWords { uint pointWords[]; };  // R^3 per brick
#define CASES_BINDING 2
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uvec4 cells;      // cells per axis, w = log2(B)
  uvec4 bricks;     // bricks per axis, w = bricks of this batch (those it emits and the next layer's)
  uint ownActive;   // bricks the batch emits
} pc;

void main() {
  uint B = 1u << pc.cells.w, R = B + 1u;
  uint r = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || a >= pc.bricks.w) return;
  uint lz = divideSmall(r, R), ly = r - lz * R;
  uvec4 seg = segments[a];
  uvec3 b = unpackBrick(seg.x);
  uint row = a * R * R + r;
  uint v = vertexSegments[segmentOf(seg, seg.y, R, ly, lz)];
  // The next layer's bricks (a >= ownActive) get their point words alone: this batch's triangles
  // of its last layer use the vertices on their lower faces.
  bool own = a < pc.ownActive;
  uvec3 e = edges[row].xyz;
  for (uint points = e.x | e.y | e.z; points != 0u; points &= points - 1u) {
    uint x = findLSB(points);
    uint bits = ((e.x >> x) & 1u) | (((e.y >> x) & 1u) << 1) | (((e.z >> x) & 1u) << 2);
    pointWords[row * R + x] = (v << 3) | bits;
    if (!own) {
      v += bitCount(bits);
      continue;
    }
    for (; bits != 0u; bits &= bits - 1u) vertexSources[v++] = uvec2(a, (r << 7) | (x << 2) | uint(findLSB(bits)));
  }
  if (!own) return;
  uvec3 g0 = b << pc.cells.w;
  if (ly >= B || lz >= B || g0.y + ly >= pc.cells.y || g0.z + lz >= pc.cells.z) return;
  uint m = masks[row], my = masks[row + 1u], mz = masks[row + R], myz = masks[row + R + 1u];
  uint t = triangleSegments[segmentOf(seg, seg.z, B, ly, lz)];
  // Cells whose corners are not all inside or all outside (configurations 0 and 255 have no
  // triangle): bit x of `inside` / `outside` is set when the cell's corners x and x + 1 of all four
  // rows are inside / outside.
  uint all4 = m & my & mz & myz, any4 = m | my | mz | myz;
  uint inside = all4 & (all4 >> 1), outside = ~(any4 | (any4 >> 1));
  uint xEnd = min(pc.cells.x - g0.x, B);
  uint faces = (b.x + 1u < pc.bricks.x ? 1u : 0u) | (b.y + 1u < pc.bricks.y ? 2u : 0u) | (b.z + 1u < pc.bricks.z ? 4u : 0u);
  uint tag = ((ly + (lz << pc.cells.w)) << 15) | (faces << 23);
  for (uint cells = ~(inside | outside) & ((1u << xEnd) - 1u); cells != 0u; cells &= cells - 1u) {
    uint x = findLSB(cells);
    uint config = ((m >> x) & 3u) | (((my >> x) & 3u) << 2) | (((mz >> x) & 3u) << 4) | (((myz >> x) & 3u) << 6);
    uint n = cases[config].x;
    for (uint k = 0u; k < n; ++k) triangleSources[t++] = uvec2(a, config | (k << 8) | (x << 11) | tag);
  }
}
