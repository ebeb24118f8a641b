// The sparse extraction handed to a mesh sink (mesh/mesh_sink.h) batch by batch, for meshes
// larger than the host's memory: the host holds two batches' vertices and one batch's triangles,
// never the whole mesh. The runs are the in-memory mesh's, in order, so a streamed file is
// byte-identical to the file of polygonize()'s mesh of the same grid.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/vk/extract/polygonize.h"

#include <cstddef>
#include <cstdint>
#include <functional>

namespace blobvk::vk {

// Active bricks per batch when options.maxBatchBricks is 0 (the host's share of the mesh).
inline constexpr std::uint32_t kStreamedBatchBricks = 4096;

// A batch's triangles may use vertices of the next batch (sparse_batches.h), so they go to the
// sink once the next batch's vertices have. `progress(done, total)` after each batch. Needs the
// sparse extraction (options.sparse, no tiled vertex pass); throws VulkanError otherwise.
void polygonizeStreamed(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                        const GpuPolygonizeOptions& options, mesh::MeshSink& sink, GpuStats* stats = nullptr,
                        const std::function<void(std::size_t done, std::size_t total)>& progress = {});

}  // namespace blobvk::vk
