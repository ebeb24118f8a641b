#version 450
// One invocation at the start of a slab's emit pass (vk/extract/slab_polygonizer.cpp): checks the slab's
// vertex and triangle counts (draw_args.comp's words 11 and 12) against the
// capacities of the caller's output buffers. Word 10 gets the overflow bits (1: vertices,
// 2: triangles; 0 when everything fits). On overflow the slab's triangles leave the indexed
// draw (word 0 back to the earlier slabs' indices), so an engine drawing from these arguments
// never reads an index that was not written or one naming a vertex that was not. The vertex and
// triangle passes clamp their own writes to the capacities (push constants).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 1) in;

layout(std430, set = 0, binding = 0) buffer Args { uint args[]; };

layout(push_constant) uniform Push {
  uint vertexCapacity, triangleCapacity;  // of this slab's outputs
} pc;

void main() {
  uint vertices = args[11], triangles = args[12];
  uint overflow = (vertices > pc.vertexCapacity ? 1u : 0u) | (triangles > pc.triangleCapacity ? 2u : 0u);
  args[10] = overflow;
  if (overflow != 0u) args[0] = 3u * (args[6] - triangles);  // the earlier slabs' triangles only
}
