#version 450
// One invocation: turns a slab's scan totals into a VkDrawIndexedIndirectCommand (words 0-4)
// followed by the running vertex and triangle counts (words 5, 6), so an engine can draw the
// mesh without reading counts back, and a VkDispatchIndirectCommand (words 7-9) with one lane
// per vertex of the slab for the vertex pass (2-D when it needs more than 65535 groups, as
// vk::groupsFor does), then (words 10-12) no overflow yet and the slab's own vertex and triangle
// counts, which emit_limits.comp checks against the output capacities.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 1) in;

layout(std430, set = 0, binding = 0) readonly buffer VertexOffsets { uint vertexOffsets[]; };
layout(std430, set = 0, binding = 1) readonly buffer Totals { uint totals[]; };  // [vertices, triangles]
layout(std430, set = 0, binding = 2) writeonly buffer Args { uint args[]; };

layout(push_constant) uniform Push {
  uint ownedPoints;   // points whose vertices this slab owns
  uint lastSlab;      // 1: the slab owns every classified point
  uint vertexBase, triangleBase;
  uint workgroupSize;  // of the vertex pass
} pc;

void main() {
  uint vertices = pc.lastSlab != 0u ? totals[0] : vertexOffsets[pc.ownedPoints];
  uint triangles = totals[1];
  args[0] = 3u * (pc.triangleBase + triangles);
  args[1] = 1u;
  args[2] = 0u;
  args[3] = 0u;
  args[4] = 0u;
  args[5] = pc.vertexBase + vertices;
  args[6] = pc.triangleBase + triangles;
  uint groups = (vertices + pc.workgroupSize - 1u) / pc.workgroupSize;
  uint x = min(groups, 65535u);
  args[7] = x;
  args[8] = x == 0u ? 0u : (groups + x - 1u) / x;
  args[9] = 1u;
  args[10] = 0u;  // emit_limits.comp's overflow bits
  args[11] = vertices;
  args[12] = triangles;
}
