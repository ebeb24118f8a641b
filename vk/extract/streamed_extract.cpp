#include "blobvk/vk/extract/streamed_extract.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <utility>

namespace blobvk::vk {

void polygonizeStreamed(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                        const GpuPolygonizeOptions& options, mesh::MeshSink& sink, GpuStats* stats,
                        const std::function<void(std::size_t, std::size_t)>& progress) {
  if (!options.sparse || options.tiledVertexPass)
    throw VulkanError("GPU polygonizer: streaming needs the sparse extraction (not the dense one, nor tiled vertices)");
  // A batch's output is on the host twice over (its vertices wait for the next batch's
  // triangles), so batches are kept small: 4096 active bricks of 16^3 cells hold some 50-100 MB
  // of mesh on the scenes shipped, where the device's limit alone would allow a quarter of its
  // memory per batch.
  GpuPolygonizeOptions streamed = options;
  if (streamed.maxBatchBricks == 0) streamed.maxBatchBricks = kStreamedBatchBricks;
  GpuStats s;
  // `current` receives a batch; `previous` holds the batch before, whose triangles wait for
  // `current`'s vertices. Cleared, not freed, so each keeps the largest batch's capacity.
  mesh::TriMesh current, previous;
  std::uint64_t previousFirst = 0, currentFirst = 0;
  bool pending = false;
  SparseBatchSink batches;
  batches.into = [&]() -> mesh::TriMesh& {
    current.positions.clear();
    current.normals.clear();
    current.colours.clear();
    current.triangles.clear();
    current.edgeKeys.clear();
    return current;
  };
  std::size_t currentBatch = 0;
  batches.meshOf = [&](std::size_t batch) -> mesh::TriMesh& { return batch == currentBatch ? current : previous; };
  batches.done = [&](std::size_t batch, std::size_t count) {
    sink.vertices(current.positions, current.normals, current.colours);
    if (pending) sink.triangles(previous.triangles, mesh::VertexWindow{previousFirst, previous.positions, current.positions});
    previousFirst = currentFirst;
    currentFirst += current.positions.size();
    std::swap(previous, current);
    currentBatch = batch + 1;
    pending = true;
    if (progress) progress(batch + 1, count);
  };
  runSparseExtraction(device, program, grid, streamed, batches, s);
  if (pending) sink.triangles(previous.triangles, mesh::VertexWindow{previousFirst, previous.positions, {}});
  if (stats) *stats = s;
}

}  // namespace blobvk::vk
