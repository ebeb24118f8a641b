// One mesh from several Vulkan devices (docs/vulkan.md, "Several devices"): the sparse
// extraction's batches of brick layers (sparse_batches.h) spread over the devices, one thread
// and one set of pipelines and buffers per device, joined in batch order. The split is the MPI
// ranks' contract (apps/mesh_mpi.h) at batch granularity: who computes a batch never changes
// its bytes, so the mesh is the one device's, byte for byte, whatever the devices and their speed.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/extract/polygonize.h"

#include <cstddef>
#include <functional>
#include <span>
#include <vector>

namespace blobvk::vk {

// The first device classifies the bricks and hands the classification (8 bytes per brick of the
// grid, at most) to the others; then each device takes the next batch when it is free (a device
// never runs more than 2 x devices batches ahead of the join, so finished pieces waiting for an
// earlier batch stay bounded). With options.maxBatchBricks 0, batches end at the layer boundary
// nearest an equal share, active bricks / (devices x options.batchesPerDevice), and within the
// smallest of every device's memory limits (sparse_batches.h): each device obeys its own budget. The devices must
// compute the same floats (the same driver, or drivers that give the same mesh alone) and be
// distinct Device objects (two may share one VkPhysicalDevice). One device: polygonize().
// Needs the sparse extraction (not options.sparse = false or tiledVertexPass); throws
// VulkanError otherwise, and rethrows the first error of any device after stopping the others.
// `stats`: the job (field, extract and read-back summed over the devices; submits, evaluations
// summed; deviceBytes the most any one device held); `perDevice`: each device's own share
// (batches, submits, its busy seconds, its device bytes).
//
// `host` (optional): one more worker beside the devices, on its own thread, taking batches as a
// device does (e.g. the CPU polygonizer, cpu::polygonizeLayerRange). It is given the brick
// layers [firstLayer, endLayer) of `brickCells`-cell bricks (options.brickCells, or smaller where
// a large grid's layer pairs need it, sparse_polygonizer.h) and returns their piece: their
// vertices (positions, normals, colours, edge keys) in global order and their triangles with
// indices counted from the piece's first vertex, corners on the next layer's vertices numbered
// past its own. It must give the devices' bytes, so every device must be CPU-type (lavapipe:
// its floats are the CPU's; throws VulkanError otherwise). With a host worker one device is
// enough, each worker gets at least 4 batches (their speeds differ), and `perDevice` ends with
// the host's share.
struct HostBatchWorker {
  std::function<mesh::TriMesh(std::uint32_t firstLayer, std::uint32_t endLayer, std::uint32_t brickCells)> run;
};
mesh::TriMesh polygonizeOnDevices(std::span<Device* const> devices, const blobtree::Program& program,
                                  const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options = {},
                                  GpuStats* stats = nullptr, std::vector<GpuStats>* perDevice = nullptr,
                                  const HostBatchWorker* host = nullptr);

// The same job handed to a mesh sink in batch order, for meshes larger than the host's memory
// (streamed_extract.h): batches of at most kStreamedBatchBricks active bricks where
// options.maxBatchBricks is 0, and the host holds the pieces waiting for the join (at most 2 x
// workers) and one more. The sink gets the mesh of polygonizeStreamed() on one device, so a
// streamed file is byte-identical to one device's. `progress(done, total)` after each batch.
void polygonizeOnDevicesStreamed(std::span<Device* const> devices, const blobtree::Program& program,
                                 const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options,
                                 mesh::MeshSink& sink, GpuStats* stats = nullptr,
                                 std::vector<GpuStats>* perDevice = nullptr, const HostBatchWorker* host = nullptr,
                                 const std::function<void(std::size_t done, std::size_t total)>& progress = {});

}  // namespace blobvk::vk
