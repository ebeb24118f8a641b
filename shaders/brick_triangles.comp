#version 450
// Sparse extraction, pass 8: the batch's triangles, in cell order then case-table order, from
// where brick_sources.comp says each comes from. A corner's vertex index is the point word of its
// edge's start point (brick_sources.comp: the point's first vertex and its crossing edges), in
// the brick that owns the point (this one, or the neighbour whose lower face holds it,
// brick_neighbours.comp), plus the edge's rank among the point's crossing edges: the global
// edge-key order of the CPU reference.
// One invocation per FOUR triangles: llvmpipe runs each storage load or store instruction as a
// loop over the lanes, whatever its width, so four triangles' sources come in two uvec4 loads
// and their twelve indices go out in three uvec4 stores (instead of four and twelve). The host
// rounds the source and index buffers up to whole groups of four; the indices past the batch's
// count are never read back.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer PointWords { uint pointWords[]; };
layout(std430, set = 0, binding = 2) readonly buffer Neighbours { uint neighbours[]; };
layout(std430, set = 0, binding = 3) readonly buffer TriangleSources { uvec4 triangleSourcePairs[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Indices { uvec4 indexQuads[]; };
#define CASES_BINDING 0
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uint log2B;
  uint triangles;   // the batch's triangle count
  uint vertexBase;  // vertices of the batches before this one
} pc;

// The three vertex indices of the triangle from `source`.
uvec3 triangleCorners(uvec2 source) {
  uint a = source.x, k = (source.y >> 8) & 7u, x = (source.y >> 11) & 15u, cellRow = (source.y >> 15) & 255u;
  uint faces = source.y >> 23;
  uint B = 1u << pc.log2B, R = B + 1u;
  uvec3 cell = uvec3(x, cellRow & (B - 1u), cellRow >> pc.log2B);
  uvec4 entry = cases[source.y & 255u];
  uvec3 corners;
  for (uint i = 0u; i < 3u; ++i) {
    uint e = caseEdge(entry, k * 3u + i);
    uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
    uvec3 p = cell + (axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u)));
    // A point on an upper face belongs to the neighbour there, unless the brick is the grid's last.
    uvec3 up = uvec3(p.x == B && (faces & 1u) != 0u ? 1u : 0u, p.y == B && (faces & 2u) != 0u ? 1u : 0u,
                     p.z == B && (faces & 4u) != 0u ? 1u : 0u);
    uint side = up.x | (up.y << 1) | (up.z << 2);
    uint owner = a;
    if (side != 0u) owner = neighbours[a * 8u + side];  // a masked-off lane skips the load
    uvec3 local = p - up * B;
    uint word = pointWords[((owner * R + local.z) * R + local.y) * R + local.x];
    uint rank = bitCount(word & ((1u << axis) - 1u));
    corners[i] = pc.vertexBase + (word >> 3) + rank;
  }
  return corners;
}

void main() {
  uint q = linearInvocation();
  if (4u * q >= pc.triangles) return;
  uvec4 s01 = triangleSourcePairs[2u * q], s23 = triangleSourcePairs[2u * q + 1u];
  // Past the batch's last triangle the sources were never written: take the group's first
  // (valid) one instead, and let the host drop its indices.
  uint n = pc.triangles - 4u * q;
  uvec2 first = s01.xy;
  uvec3 t0 = triangleCorners(first);
  uvec3 t1 = triangleCorners(n > 1u ? s01.zw : first);
  uvec3 t2 = triangleCorners(n > 2u ? s23.xy : first);
  uvec3 t3 = triangleCorners(n > 3u ? s23.zw : first);
  indexQuads[3u * q] = uvec4(t0, t1.x);
  indexQuads[3u * q + 1u] = uvec4(t1.yz, t2.xy);
  indexQuads[3u * q + 2u] = uvec4(t2.z, t3);
}
