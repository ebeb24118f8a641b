#include "blobvk/vk/render/raycast.h"

#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/render/raycast_lipschitz.h"

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace blobvk::vk {
namespace {

std::uint32_t packBackground(const std::array<float, 3>& c) {
  std::uint32_t v = 255u << 24;
  for (int i = 0; i < 3; ++i) v |= std::uint32_t(std::clamp(c[i], 0.0f, 1.0f) * 255.0f + 0.5f) << (8 * i);
  return v;
}

std::uint32_t floatBits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

}  // namespace

Raycaster::Raycaster(Device& device, const blobtree::Program& program, const RaycastOptions& options)
    : device_(device), options_(options), program_(uploadProgram(device, program, options.traversal)) {
  region_ = program.bounds;
  if (!region_.finite()) {
    // An unbounded warp at the root: march the box the caller gives (the scene's grid bounds),
    // else the unit-ish box around the primitives.
    region_ = options.unboundedRegion;
    if (region_.empty() || !region_.finite()) {
      region_ = blobtree::Aabb{};
      region_.lo = glm::vec3(-2.0f);
      region_.hi = glm::vec3(2.0f);
    }
  }
  cells_ = lipschitzGrid(program, region_, options.lipschitzCells, options.lipschitzWork);
  lipschitz_ = cells_.largest();
  cellBuffer_ = device.createBuffer(cells_.cells.size() * 4);
  device.upload(cellBuffer_, cells_.cells.data(), cells_.cells.size() * 4);
  exhausted_ = device.createBuffer(16, MemoryUse::Readback);
  // llvmpipe ends a pixel's loops after 65,535 iterations in all (vk/extract/loop_limit.h); the
  // kernel counts its own and stops a ray short of them (a margin for the few it does not tick).
  const std::uint64_t loops = loopIterationLimit(device.info());
  loopBudget_ = loops == ~0ull ? 3.0e38f : float(loops - 256);
}

std::uint32_t Raycaster::exhaustedRays() const {
  std::uint32_t n = 0;
  device_.download(exhausted_, &n, 4);
  return n;
}

void Raycaster::recordRaycast(Recorder& rec, const Camera& camera, std::uint32_t width,
                              std::uint32_t height, const BufferRange& pixels) const {
  const float aspect = float(width) / float(height);
  const float tanY = std::tan(glm::radians(camera.fovYDeg) * 0.5f);
  const glm::vec3 forward = glm::normalize(camera.target - camera.eye);
  const glm::vec3 right = glm::normalize(glm::cross(forward, camera.up));
  const glm::vec3 up = glm::cross(right, forward);
  const float diagonal = glm::length(region_.hi - region_.lo);
  struct {
    float eyeLipschitz[4], right[4], up[4], forward[4], lo[4], hi[4];
    std::uint32_t sizeCodeBackground[4], cells[4];
  } push{{camera.eye.x, camera.eye.y, camera.eye.z, lipschitz_},
         {right.x * tanY * aspect, right.y * tanY * aspect, right.z * tanY * aspect,
          options_.minStepFraction * diagonal},
         {up.x * tanY, up.y * tanY, up.z * tanY, options_.gradientFraction * diagonal},
         {forward.x, forward.y, forward.z, float(options_.bisections)},
         {region_.lo.x, region_.lo.y, region_.lo.z, float(options_.maxSteps)},
         {region_.hi.x, region_.hi.y, region_.hi.z, loopBudget_},
         {width, height, program_.codeLength, packBackground(options_.background)},
         {cells_.dims[0], cells_.dims[1], cells_.dims[2], floatBits(options_.minRise)}};
  static_assert(sizeof(push) == 128);
  const KernelPtr k = evaluatorKernel(device_, program_, "raycast", options_.workgroupSize, options_.traversal);
  const auto pb = program_.bindings();
  const BufferRange bind[8] = {pb[0], pb[1], pb[2], pb[3], pb[4], pixels, cellBuffer_, exhausted_};
  const Groups g = groupsFor(std::uint64_t(width) * height, options_.workgroupSize);
  rec.fill(exhausted_, 0u);
  rec.computeBarrier();  // the reset -> the shader's atomic adds
  rec.dispatch(*k, bind, &push, sizeof(push), g.x, g.y);
  rec.computeBarrier();
}

Image Raycaster::render(const Camera& camera, std::uint32_t width, std::uint32_t height, RaycastStats* stats) {
  Buffer pixels = device_.createBuffer(std::uint64_t(width) * height * 4, MemoryUse::Readback);
  const auto t0 = std::chrono::steady_clock::now();
  device_.run([&](Recorder& rec) {
    recordRaycast(rec, camera, width, height, pixels);
    rec.hostBarrier();
  });
  if (stats) {
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stats->lipschitz = lipschitz_;
    stats->exhaustedRays = exhaustedRays();
  }
  Image image{width, height, std::vector<std::uint8_t>(std::size_t(width) * height * 4)};
  std::memcpy(image.rgba.data(), pixels.mapped(), image.rgba.size());
  return image;
}

}  // namespace blobvk::vk
