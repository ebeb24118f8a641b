// Direct ray-casting of a Program's field into an image with a compute shader (no mesh, no
// graphics queue): see shaders/raycast.comp and the step bound in raycast_lipschitz.h.
//
// recordRaycast() records one dispatch into the caller's command buffer. It expects the program
// buffers uploaded (and visible to compute) and the pixel buffer free of pending access; it ends
// with Recorder::computeBarrier (pixel writes visible to compute, transfer and indirect reads).
#pragma once

#include "blobtree/program.h"
#include "vk/context.h"
#include "vk/gpu_program.h"
#include "vk/render_camera.h"
#include "vk/render_image.h"

#include <array>
#include <cstdint>

namespace blobvk::vk {

struct RaycastOptions {
  std::array<float, 3> background{0.13f, 0.14f, 0.16f};  // display values, as RenderStyle's
  float minStepFraction = 2e-4f;    // smallest step, as a fraction of the bounds diagonal
  float gradientFraction = 5e-4f;   // central-difference step, fraction of the diagonal
  std::uint32_t maxSteps = 4096;    // per ray; a ray that runs out is background
  std::uint32_t bisections = 12;
  std::uint32_t workgroupSize = 64;
  Traversal traversal = Traversal::Specialised;  // the field evaluator (vk/gpu_program.h)
};

struct RaycastStats {
  double seconds = 0.0;  // submit to fence, read-back excluded
  float lipschitz = 0.0f;
};

class Raycaster {
 public:
  Raycaster(Device& device, const blobtree::Program& program, const RaycastOptions& options = {});

  // Records the dispatch writing width * height packed RGBA8 words into `pixels`.
  void recordRaycast(Recorder& rec, const Camera& camera, std::uint32_t width, std::uint32_t height,
                     const BufferRange& pixels) const;
  // Headless: allocate, dispatch, wait, read back.
  Image render(const Camera& camera, std::uint32_t width, std::uint32_t height,
               RaycastStats* stats = nullptr);

  float lipschitz() const { return lipschitz_; }
  const blobtree::Aabb& region() const { return region_; }

 private:
  Device& device_;
  RaycastOptions options_;
  GpuProgram program_;
  blobtree::Aabb region_;
  float lipschitz_ = 0.0f;
};

}  // namespace blobvk::vk
