#version 450
// Sparse extraction, tiled vertex pass, step 2 of 3: one invocation turns the tiles' vertex counts
// (brick_vertex_tile_counts.comp) into each tile's run of the vertex lists (exclusive prefix sum,
// in tile order), the cursors brick_vertex_tile_lists.comp advances, and the
// VkDispatchIndirectCommand of each tile's vertex kernel (2-D past 65535 groups, as vk::groupsFor).
// Eight words per tile: groups x, y, z, the tile's vertex count, its first list entry.
layout(local_size_x = 1) in;

layout(std430, set = 0, binding = 0) buffer Counters { uint counters[]; };  // [tile] counts, [tiles + tile] cursors
layout(std430, set = 0, binding = 1) writeonly buffer Args { uint args[]; };

layout(push_constant) uniform Push {
  uint tiles;
  uint workgroupSize;  // of the vertex kernels
} pc;

void main() {
  uint first = 0u;
  for (uint t = 0u; t < pc.tiles; ++t) {
    uint count = counters[t];
    uint groups = (count + pc.workgroupSize - 1u) / pc.workgroupSize;
    uint x = min(groups, 65535u);
    args[t * 8u] = x;
    args[t * 8u + 1u] = x == 0u ? 0u : (groups + x - 1u) / x;
    args[t * 8u + 2u] = 1u;
    args[t * 8u + 3u] = count;
    args[t * 8u + 4u] = first;
    counters[pc.tiles + t] = first;
    first += count;
  }
}
