#version 450
// One invocation: the vertex count of one field tile in a slab, from the scanned row counts, and
// the VkDispatchIndirectCommand of its vertex pass (2-D past 65535 groups, as vk::groupsFor).
// Words per tile: groups x, y, z, then the vertex count.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 1) in;

layout(std430, set = 0, binding = 0) readonly buffer RowScan { uint rowScan[]; };
layout(std430, set = 0, binding = 1) readonly buffer Totals { uint totals[]; };  // [2] all rows' vertices
layout(std430, set = 0, binding = 2) writeonly buffer Args { uint args[]; };

layout(push_constant) uniform Push {
  uint rowBase, rows, totalRows;
  uint tileIndex;
  uint workgroupSize;  // of the vertex pass
} pc;

void main() {
  uint end = pc.rowBase + pc.rows < pc.totalRows ? rowScan[pc.rowBase + pc.rows] : totals[2];
  uint count = end - rowScan[pc.rowBase];
  uint groups = (count + pc.workgroupSize - 1u) / pc.workgroupSize;
  uint x = min(groups, 65535u);
  uint w = pc.tileIndex * 4u;
  args[w] = x;
  args[w + 1u] = x == 0u ? 0u : (groups + x - 1u) / x;
  args[w + 2u] = 1u;
  args[w + 3u] = count;
}
