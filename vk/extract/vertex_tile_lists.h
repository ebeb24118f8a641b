// The vertex pass's per-tile lists (GpuPolygonizeOptions::sparseVertexTiles) made on the host, for
// CPU devices whose buffers the host maps cached: what brick_vertex_tile_counts, _args and _lists
// do on a GPU. On llvmpipe those passes take an atomic add per vertex, each a locked instruction
// that the two cores pass one cache line back and forth for (tower at 512 cells: about 30 ms a
// pass against 2-3 ms here). The lists hold each tile's vertices in ascending order; the device's
// hold them in the order of its atomics. Either way each vertex's outputs are written at its own
// index, so the mesh's bytes are the same.
#pragma once

#include <cstdint>

namespace blobvk::vk {

// sources: the batch's vertex sources (brick_sources.comp: two words a vertex, the batch brick
// first); brickTile: each batch brick's tile. Writes lists (a word per vertex, tile by tile) and
// args (8 words per tile: the indirect dispatch's group counts x, y, z for `workgroupSize`, the
// tile's count and its first entry in lists), as brick_vertex_tile_args.comp lays them out.
void listVerticesByTile(const std::uint32_t* sources, std::uint32_t vertices, const std::uint32_t* brickTile,
                        std::uint32_t tiles, std::uint32_t workgroupSize, std::uint32_t* lists, std::uint32_t* args);

}  // namespace blobvk::vk
