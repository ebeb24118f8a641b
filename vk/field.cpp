#include "vk/field.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>

namespace blobvk::vk {

std::uint32_t layersPerBrick(const Device& device, const blobtree::GridSpec& grid,
                             std::uint64_t maxBytes, std::uint64_t bytesPerPoint) {
  const auto pts = grid.points();
  const std::uint64_t layerBytes = std::uint64_t(pts.x) * std::uint64_t(pts.y) * bytesPerPoint;
  const std::uint64_t budget =
      std::min<std::uint64_t>(maxBytes, device.info().limits.maxStorageBufferRange);
  return std::uint32_t(std::max<std::uint64_t>(1, budget / std::max<std::uint64_t>(layerBytes, 1)));
}

void recordFieldSlab(Recorder& rec, const GpuProgram& program, Traversal traversal,
                     std::uint32_t workgroupSize, const blobtree::GridSpec& grid,
                     std::uint32_t k0, std::uint32_t layers, const Buffer& out) {
  const Kernel& k = evaluatorKernel(rec.device(), program, "field_grid", 6, workgroupSize, traversal);
  const auto pts = grid.points();
  struct {
    float origin[3], cell;
    std::uint32_t nx, ny, count, k0, codeLength;
  } push{{grid.origin.x, grid.origin.y, grid.origin.z}, grid.cellSize, std::uint32_t(pts.x),
         std::uint32_t(pts.y), std::uint32_t(pts.x) * std::uint32_t(pts.y) * layers, k0,
         program.codeLength};
  const auto pb = program.bindings();
  const BufferRange bind[6] = {pb[0], pb[1], pb[2], pb[3], pb[4], BufferRange(out)};
  const Groups g = groupsFor(push.count, workgroupSize);
  rec.dispatch(k, bind, &push, sizeof(push), g.x, g.y);
}

std::vector<float> evaluateFieldOnGrid(Device& device, const blobtree::Program& program,
                                       const blobtree::GridSpec& grid, const FieldOptions& options,
                                       FieldStats* stats) {
  const auto pts = grid.points();
  std::vector<float> field(grid.pointCount());
  if (field.empty()) return field;
  const GpuProgram gpu = uploadProgram(device, program, options.traversal, options.codegen);
  const std::uint32_t brickLayers = layersPerBrick(device, grid, options.maxBrickBytes, 4);
  const std::uint64_t layerPoints = std::uint64_t(pts.x) * std::uint64_t(pts.y);
  Buffer out = device.createBuffer(layerPoints * std::min<std::uint32_t>(brickLayers, pts.z) * 4);
  FieldStats s;
  for (std::uint32_t k0 = 0; k0 < std::uint32_t(pts.z); k0 += brickLayers) {
    const std::uint32_t layers = std::min<std::uint32_t>(brickLayers, std::uint32_t(pts.z) - k0);
    const auto t0 = std::chrono::steady_clock::now();
    device.run([&](Recorder& rec) {
      recordFieldSlab(rec, gpu, options.traversal, options.workgroupSize, grid, k0, layers, out);
      rec.hostBarrier();
    });
    s.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    device.download(out, field.data() + k0 * layerPoints, layerPoints * layers * 4);
    ++s.bricks;
  }
  s.evaluations = field.size();
  if (stats) *stats = s;
  return field;
}

}  // namespace blobvk::vk
