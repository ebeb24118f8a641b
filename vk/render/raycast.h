// Direct ray-casting of a Program's field into an image with a compute shader (no mesh, no
// graphics queue): see shaders/raycast.comp and the step bound in raycast_lipschitz.h.
//
// recordRaycast() records one dispatch into the caller's command buffer. It expects the program
// buffers uploaded (and visible to compute) and the pixel buffer free of pending access; it ends
// with Recorder::computeBarrier (pixel writes visible to compute, transfer and indirect reads).
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/render/raycast_lipschitz.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/render/render_image.h"

#include <array>
#include <cstdint>

namespace blobvk::vk {

// The colour of a pixel whose ray ran out of its step budget inside the bounds (a surface may
// lie behind it): opaque magenta, packed RGBA8 as the pixel buffer holds it.
inline constexpr std::uint32_t kRaycastBudgetMarker = 0xffff00ffu;

struct RaycastOptions {
  std::array<float, 3> background{0.13f, 0.14f, 0.16f};  // display values, as RenderStyle's
  // The box to march where the program's bounds are infinite (an unbounded warp at the root,
  // such as a bend): the scene's grid bounds, as the polygonizers use; empty: [-2, 2]^3.
  blobtree::Aabb unboundedRegion{};
  // The step floor near the surface: min(minStepFraction * bounds diagonal, minRise / L) in a
  // cell of bound L. No crossing where the field rises minRise or more above the iso value is
  // ever stepped over, however thin (it is at least 2 minRise / L long).
  float minStepFraction = 2e-4f;
  float minRise = 2e-3f;
  float gradientFraction = 5e-4f;   // central-difference step, fraction of the diagonal
  // Per ray, cell crossings included; a ray that runs out inside the bounds is counted
  // (RaycastStats::exhaustedRays, Raycaster::exhaustedRays) and drawn kRaycastBudgetMarker. So is
  // one that would outrun llvmpipe's 65,535 loop iterations per pixel (vk/extract/loop_limit.h),
  // which a long interpreted or looped program reaches in fewer steps.
  std::uint32_t maxSteps = 4096;
  // The bounds split into at most this many cells along the longest side, each with its own
  // Lipschitz bound (raycast_lipschitz.h: lipschitzGrid); 1 = one bound for the whole scene.
  // Fewer for long programs: cells x instructions stays under lipschitzWork (the bounds are
  // computed on the CPU at construction, ~0.1 s at the default).
  std::uint32_t lipschitzCells = 64;
  std::uint64_t lipschitzWork = 8u << 20;
  std::uint32_t bisections = 12;
  std::uint32_t workgroupSize = 64;
  Traversal traversal = Traversal::Specialised;  // the field evaluator (vk/eval/gpu_program.h)
};

struct RaycastStats {
  double seconds = 0.0;  // submit to fence, read-back excluded
  float lipschitz = 0.0f;  // the largest of the per-cell bounds
  std::uint32_t exhaustedRays = 0;  // rays that ran out of their step budget (marked pixels)
};

class Raycaster {
 public:
  Raycaster(Device& device, const blobtree::Program& program, const RaycastOptions& options = {});

  // Records the dispatch writing width * height packed RGBA8 words into `pixels`, and the count
  // of rays out of budget into the Raycaster's counter (reset first: one recording in flight per
  // Raycaster).
  void recordRaycast(Recorder& rec, const Camera& camera, std::uint32_t width, std::uint32_t height,
                     const BufferRange& pixels) const;
  // The counter of the last recording, read back (its command buffer must have completed).
  std::uint32_t exhaustedRays() const;
  // Headless: allocate, dispatch, wait, read back.
  Image render(const Camera& camera, std::uint32_t width, std::uint32_t height,
               RaycastStats* stats = nullptr);

  float lipschitz() const { return lipschitz_; }  // the largest per-cell bound
  const LipschitzGrid& lipschitzCells() const { return cells_; }
  const blobtree::Aabb& region() const { return region_; }

 private:
  Device& device_;
  RaycastOptions options_;
  GpuProgram program_;
  blobtree::Aabb region_;
  float lipschitz_ = 0.0f;
  LipschitzGrid cells_;
  Buffer cellBuffer_, exhausted_;
  float loopBudget_ = 3.0e38f;  // loop iterations a pixel may run (llvmpipe's limit less a margin)
};

}  // namespace blobvk::vk
