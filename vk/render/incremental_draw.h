// The engine-facing buffers of a mesh edited incrementally (vk/extract/incremental_extract.h):
// device-local vertex attributes, indices and a VkDrawIndexedIndirectCommand that an engine
// draws with vkCmdDrawIndexedIndirect, patched in place after each edit. An update changes only
// the vertices and triangles of IncrementalGpuStats::verticesChanged / trianglesChanged (the
// re-run rows and what moved after them); those ranges alone are copied, from one staging
// buffer, by commands recorded into the caller's command buffer, and the draw command's index
// count is written by a copy in the same command buffer: the engine's frame never reads a
// count back. When the new counts exceed the buffers' capacity, new buffers (with headroom) are
// made and filled whole; view() then names them.
//
// Recording contract (record): outside a render pass; the buffers must not be in use by earlier
// submitted work (wait for the last frame that drew them). Leaves a barrier from the transfer
// writes to vertex input and indirect draw. The staging buffer lives until the next record.
#pragma once

#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/extract/row_splice.h"
#include "blobvk/vk/render/render_mesh.h"

#include <array>
#include <cstdint>

namespace blobvk::vk {

struct DrawPatchStats {
  bool inPlace = false;          // the buffers were patched (false: made anew and filled whole)
  std::uint64_t bytesCopied = 0;  // host to device, draw command included
};

class IncrementalDrawBuffers {
 public:
  // `headroom`: capacity over the counts when buffers are made (at least 1). Vertices without
  // colours are drawn in `defaultColour`; the mesh must carry normals.
  explicit IncrementalDrawBuffers(Device& device, double headroom = 1.25,
                                  std::array<float, 3> defaultColour = {0.8f, 0.8f, 0.8f});
  IncrementalDrawBuffers(const IncrementalDrawBuffers&) = delete;
  IncrementalDrawBuffers& operator=(const IncrementalDrawBuffers&) = delete;

  // Records the copies that make the buffers hold `mesh`, given which of its elements changed
  // since the last record (all of them the first time: pass {0, size}).
  DrawPatchStats record(Recorder& rec, const mesh::TriMesh& mesh, ChangedRange vertices, ChangedRange triangles);

  MeshView view() const;  // indirect command at offset 0
  std::uint64_t vertexCapacity() const { return vertexCapacity_; }
  std::uint64_t triangleCapacity() const { return triangleCapacity_; }
  // The device buffers, for hosts that bind them themselves (and for tests).
  const Buffer& positions() const { return positions_; }
  const Buffer& normals() const { return normals_; }
  const Buffer& colours() const { return colours_; }
  const Buffer& indices() const { return indices_; }
  const Buffer& drawCommand() const { return drawCommand_; }

 private:
  Device& device_;
  double headroom_;
  std::array<float, 3> defaultColour_;
  Buffer positions_, normals_, colours_, indices_, drawCommand_, staging_;
  std::uint64_t vertexCapacity_ = 0, triangleCapacity_ = 0;
  bool filled_ = false;
};

}  // namespace blobvk::vk
