#version 450
// Sparse extraction, pass 8: one invocation per triangle of the batch, in cell order then
// case-table order, from where brick_sources.comp says it comes from. A vertex index is the first
// vertex of the row holding the edge's start point (edges.w, in the brick that owns the point:
// this one, or the neighbour whose lower face holds it, brick_neighbours.comp), plus the vertices
// before the point in that row, plus the edge's rank among the point's crossing edges: the global
// edge-key order of the CPU reference.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer Edges { uvec4 edges[]; };
layout(std430, set = 0, binding = 2) readonly buffer Neighbours { uint neighbours[]; };
layout(std430, set = 0, binding = 3) readonly buffer TriangleSources { uvec2 triangleSources[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Indices { uint indices[]; };
#define CASES_BINDING 0
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uint log2B;
  uint triangles;   // the batch's triangle count
  uint vertexBase;  // vertices of the batches before this one
} pc;

void main() {
  uint t = linearInvocation();
  if (t >= pc.triangles) return;
  uvec2 source = triangleSources[t];
  uint a = source.x, k = (source.y >> 8) & 7u, x = (source.y >> 11) & 15u, cellRow = (source.y >> 15) & 255u;
  uint faces = source.y >> 23;
  uint B = 1u << pc.log2B, R = B + 1u;
  uvec3 cell = uvec3(x, cellRow & (B - 1u), cellRow >> pc.log2B);
  uvec4 entry = cases[source.y & 255u];
  for (uint i = 0u; i < 3u; ++i) {
    uint e = caseEdge(entry, k * 3u + i);
    uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
    uvec3 p = cell + (axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u)));
    // A point on an upper face belongs to the neighbour there, unless the brick is the grid's last.
    uvec3 up = uvec3(p.x == B && (faces & 1u) != 0u ? 1u : 0u, p.y == B && (faces & 2u) != 0u ? 1u : 0u,
                     p.z == B && (faces & 4u) != 0u ? 1u : 0u);
    uint owner = neighbours[a * 8u + (up.x | (up.y << 1) | (up.z << 2))];
    uvec3 local = p - up * B;
    uvec4 oe = edges[owner * R * R + local.z * R + local.y];
    uint bits = ((oe.x >> local.x) & 1u) | (((oe.y >> local.x) & 1u) << 1) | (((oe.z >> local.x) & 1u) << 2);
    uint rank = bitCount(bits & ((1u << axis) - 1u));
    indices[t * 3u + i] = pc.vertexBase + oe.w + rowVerticesBefore(oe.xyz, local.x) + rank;
  }
}
