// The offscreen mesh renderer: a graphics pipeline (Blinn-Phong, per-vertex colour, optional
// wireframe overlay) that draws a mesh from device buffers, with an explicit index count or from
// a VkDrawIndexedIndirectCommand left on the GPU by the polygonizer (no read-back).
//
// Recording contract (MeshPipeline::recordDraw): call inside a render pass compatible with the
// one given at construction (OffscreenTarget's, or the host's), viewport and scissor dynamic and
// already set. The vertex, index and indirect buffers must be visible to VERTEX_INPUT and
// DRAW_INDIRECT (a barrier from their producer: transfer or compute). Leaves the pipeline and
// vertex/index bindings changed, nothing else.
#pragma once

#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/render/render_dispatch.h"
#include "blobvk/vk/render/render_image.h"

#include <array>
#include <cstdint>
#include <memory>

namespace blobvk::vk {

struct RenderStyle {
  std::array<float, 3> background{0.13f, 0.14f, 0.16f};  // written as-is (display values)
  std::array<float, 3> defaultColour{0.8f, 0.8f, 0.8f};  // linear, for meshes without colours
  bool wireframe = false;                                 // edges over the shaded mesh
  std::array<float, 3> wireColour{0.05f, 0.05f, 0.05f};
  std::uint32_t samples = 4;                              // MSAA, clamped to what the device has
};

// A mesh on the device in the renderer's layout: float3 arrays (tightly packed) and uint32
// triangle indices. Either indexCount or an indirect command (VkDrawIndexedIndirectCommand at
// indirectOffset) says how much to draw. lineIndices (pairs) draw the wireframe.
struct MeshView {
  VkBuffer positions = VK_NULL_HANDLE, normals = VK_NULL_HANDLE, colours = VK_NULL_HANDLE;
  VkBuffer indices = VK_NULL_HANDLE;
  std::uint32_t indexCount = 0;
  VkBuffer indirect = VK_NULL_HANDLE;
  VkDeviceSize indirectOffset = 0;
  VkBuffer lineIndices = VK_NULL_HANDLE;
  std::uint32_t lineIndexCount = 0;
};

// A TriMesh uploaded for drawing. Missing normals are computed (area-weighted), missing colours
// filled with `defaultColour`; the wireframe's unique edges are built when asked.
struct UploadedMesh {
  Buffer positions, normals, colours, indices, lines;
  std::uint32_t indexCount = 0, lineIndexCount = 0;
  MeshView view() const;
};
UploadedMesh uploadMesh(Device& device, const mesh::TriMesh& mesh, const RenderStyle& style);

class MeshPipeline {
 public:
  MeshPipeline(Device& device, const RenderDispatch& rd, VkRenderPass renderPass,
               VkSampleCountFlagBits samples);
  ~MeshPipeline();
  MeshPipeline(const MeshPipeline&) = delete;
  MeshPipeline& operator=(const MeshPipeline&) = delete;

  void recordDraw(VkCommandBuffer cmd, const MeshView& mesh, const Camera& camera, float aspect,
                  const RenderStyle& style) const;

 private:
  void release();
  Device& device_;
  const RenderDispatch& rd_;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline triangles_ = VK_NULL_HANDLE, lines_ = VK_NULL_HANDLE;
};

// Headless convenience: a target of width x height, the pipeline, one submit per image.
class MeshRenderer {
 public:
  MeshRenderer(Device& device, std::uint32_t width, std::uint32_t height, const RenderStyle& style = {});
  ~MeshRenderer();

  Image render(const mesh::TriMesh& mesh, const Camera& camera);
  Image render(const MeshView& mesh, const Camera& camera);
  double lastSeconds() const { return lastSeconds_; }  // submit to fence, read-back excluded
  std::uint32_t samples() const;
  const RenderDispatch& dispatch() const { return *rd_; }

 private:
  Device& device_;
  RenderStyle style_;
  std::unique_ptr<RenderDispatch> rd_;
  std::unique_ptr<class OffscreenTarget> target_;
  std::unique_ptr<MeshPipeline> pipeline_;
  double lastSeconds_ = 0.0;
};

}  // namespace blobvk::vk
