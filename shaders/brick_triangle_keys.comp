#version 450
// Sparse extraction, pass 8 for a re-run of an edit's bricks (vk/extract/incremental_extract.cpp):
// as brick_triangles.comp, one invocation per triangle of the batch from where brick_sources.comp
// says it comes from, but each corner is written as the global edge key of its edge (point
// ((z * ny + y) * nx + x) * 3 + axis, 64 bits, low word first) instead of a vertex index. The
// bricks around a re-run are not loaded, so the vertices on its upper faces that they own have no
// index here; the host finds every corner's index from its key in the spliced mesh.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 2) readonly buffer TriangleSources { uvec2 triangleSources[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Keys { uvec2 keys[]; };
#define CASES_BINDING 0
#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  uint log2B;
  uint triangles;  // the batch's triangle count
  uint nx, ny;     // grid points per axis (edge keys)
} pc;

void main() {
  uint t = linearInvocation();
  if (t >= pc.triangles) return;
  uvec2 source = triangleSources[t];
  uint a = source.x, k = (source.y >> 8) & 7u, x = (source.y >> 11) & 15u, cellRow = (source.y >> 15) & 255u;
  uint B = 1u << pc.log2B;
  uvec3 cell = (unpackBrick(bricks[a], bricksOfPoints(uvec2(pc.nx, pc.ny), pc.log2B)) << pc.log2B) + uvec3(x, cellRow & (B - 1u), cellRow >> pc.log2B);
  uvec4 entry = cases[source.y & 255u];
  for (uint i = 0u; i < 3u; ++i) {
    uint e = caseEdge(entry, k * 3u + i);
    uint axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
    uvec3 p = cell + (axis == 0u ? uvec3(0u, u, w) : (axis == 1u ? uvec3(u, 0u, w) : uvec3(u, w, 0u)));
    // Key = ((z * ny + y) * nx + x) * 3 + axis in 64 bits (as brick_vertices_body.glsl).
    uint khi, klo, carry;
    umulExtended(p.z * pc.ny + p.y, pc.nx, khi, klo);
    klo = uaddCarry(klo, p.x, carry);
    khi += carry;
    uint h3, l3;
    umulExtended(klo, 3u, h3, l3);
    khi = khi * 3u + h3;
    l3 = uaddCarry(l3, axis, carry);
    keys[t * 3u + i] = uvec2(l3, khi + carry);
  }
}
