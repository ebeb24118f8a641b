// A GPU-polygonized mesh kept on the device for drawing: marching cubes (slab_polygonizer.h)
// writes straight into vertex/index buffers and the polygonizer's draw-arguments buffer holds the
// VkDrawIndexedIndirectCommand, so the renderer draws it with vkCmdDrawIndexedIndirect and the
// mesh never comes back to the host.
//
// Capacity: the worst case (3 vertices per grid point, 5 triangles per cell) is allocated when it
// fits the device's storage-buffer range and `maxBytes`; otherwise only the seven counter words
// of the classify pass are read back to size the buffers exactly. Grids that need more than one
// z-slab (vk/extract/polygonize.h) are drawn from the read-back mesh instead (`fromReadback`).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/render/render_mesh.h"

#include <memory>

namespace blobvk::vk {

struct GpuMesh {
  Buffer positions, normals, colours, keys, indices;
  std::unique_ptr<class SlabPolygonizer> polygonizer;  // owns the draw-arguments buffer
  UploadedMesh fallback;                                // multi-slab grids
  bool fromReadback = false;
  bool countsReadBack = false;  // true when the counts were read back to size the buffers
  MeshView view() const;
  // The triangles drawn: the draw arguments' index count, read back (a few bytes) after the run.
  std::uint64_t triangleCount(Device& device) const;
  GpuMesh();
  GpuMesh(GpuMesh&&) noexcept;
  GpuMesh& operator=(GpuMesh&&) noexcept;
  ~GpuMesh();
};

GpuMesh polygonizeForDrawing(Device& device, const blobtree::Program& program,
                             const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options = {},
                             std::uint64_t maxBytes = 256ull << 20);

}  // namespace blobvk::vk
