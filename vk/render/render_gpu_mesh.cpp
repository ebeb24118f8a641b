#include "blobvk/vk/render/render_gpu_mesh.h"

#include "blobvk/vk/extract/slab_polygonizer.h"

#include <algorithm>
#include <array>

namespace blobvk::vk {

GpuMesh::GpuMesh() = default;
GpuMesh::GpuMesh(GpuMesh&&) noexcept = default;
GpuMesh& GpuMesh::operator=(GpuMesh&&) noexcept = default;
GpuMesh::~GpuMesh() = default;

MeshView GpuMesh::view() const {
  if (fromReadback) return fallback.view();
  MeshView v;
  v.positions = positions.handle();
  v.normals = normals.handle();
  v.colours = colours.handle();
  v.indices = indices.handle();
  if (polygonizer) v.indirect = polygonizer->drawArgs().handle();
  return v;
}

std::uint64_t GpuMesh::triangleCount(Device& device) const {
  if (fromReadback) return fallback.indexCount / 3;
  if (!polygonizer) return 0;  // an empty grid
  std::uint32_t indexCount = 0;  // word 0 of the VkDrawIndexedIndirectCommand
  device.download(polygonizer->drawArgs(), &indexCount, sizeof(indexCount));
  return indexCount / 3;
}

GpuMesh polygonizeForDrawing(Device& device, const blobtree::Program& program,
                             const blobtree::GridSpec& grid, const GpuPolygonizeOptions& rawOptions,
                             std::uint64_t maxBytes) {
  GpuPolygonizeOptions options = rawOptions;
  options.normals = true;
  options.colours = true;
  GpuMesh out;
  if (grid.cells.x < 1 || grid.cells.y < 1 || grid.cells.z < 1) return out;
  auto poly = std::make_unique<SlabPolygonizer>(device, program, grid, options);
  if (poly->slabCount() != 1) {
    out.fallback = uploadMesh(device, polygonize(device, program, grid, options), RenderStyle{});
    out.fromReadback = true;
    return out;
  }
  const SlabPlan plan = poly->plan(0);
  std::uint64_t vertices = 3 * plan.ownedPoints, triangles = 5 * plan.cells;
  const std::uint64_t range = device.info().limits.maxStorageBufferRange;
  const bool worstCaseFits = vertices * 12 <= range && triangles * 12 <= range &&
                             vertices * 40 + triangles * 12 <= maxBytes;
  constexpr VkBufferUsageFlags draw = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
  auto allocate = [&] {
    out.positions = device.createBuffer(std::max<std::uint64_t>(vertices * 12, 16), MemoryUse::DeviceLocal, draw);
    out.normals = device.createBuffer(std::max<std::uint64_t>(vertices * 12, 16), MemoryUse::DeviceLocal, draw);
    out.colours = device.createBuffer(std::max<std::uint64_t>(vertices * 12, 16), MemoryUse::DeviceLocal, draw);
    out.keys = device.createBuffer(std::max<std::uint64_t>(vertices * 4, 16));
    out.indices = device.createBuffer(std::max<std::uint64_t>(triangles * 12, 16), MemoryUse::DeviceLocal, draw);
  };
  // The emit kernels write vertex attributes and indices; the draw reads them as vertex input
  // and the command from the args buffer (computeBarrier covers indirect, not vertex input).
  auto toDraw = [&](Recorder& rec) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDEX_READ_BIT |
                            VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
    device.d().vkCmdPipelineBarrier(rec.cmd(), VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                                    VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                                    0, 1, &barrier, 0, nullptr, 0, nullptr);
  };
  if (worstCaseFits) {
    allocate();
    device.run([&](Recorder& rec) {
      poly->recordClassify(rec, 0, 0, 0);
      poly->recordEmit(rec, 0, 0, {out.positions, out.normals, out.colours, out.keys, out.indices,
                                   std::uint32_t(vertices), std::uint32_t(triangles)});
      toDraw(rec);
    });
  } else {
    device.run([&](Recorder& rec) {
      poly->recordClassify(rec, 0, 0, 0);
      rec.hostBarrier();
    });
    std::array<std::uint32_t, 7> args{};
    device.download(poly->drawArgs(), args.data(), sizeof(args));
    vertices = args[5];
    triangles = args[6];
    out.countsReadBack = true;
    allocate();
    device.run([&](Recorder& rec) {
      poly->recordEmit(rec, 0, 0, {out.positions, out.normals, out.colours, out.keys, out.indices,
                                   std::uint32_t(vertices), std::uint32_t(triangles)});
      toDraw(rec);
    });
  }
  out.polygonizer = std::move(poly);
  return out;
}

}  // namespace blobvk::vk
