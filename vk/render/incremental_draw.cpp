#include "blobvk/vk/render/incremental_draw.h"

#include "blobvk/vk/device/error.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace blobvk::vk {
namespace {

constexpr VkBufferUsageFlags kDrawUsage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
constexpr std::uint64_t kCommandBytes = 5 * 4;  // VkDrawIndexedIndirectCommand

// One piece of the staging buffer: `bytes` from `from` (host), copied to `to` at `offset`.
struct Piece {
  const Buffer* to;
  std::uint64_t offset, bytes;
  const void* from;  // null: the default colour, repeated
};

}  // namespace

IncrementalDrawBuffers::IncrementalDrawBuffers(Device& device, double headroom, std::array<float, 3> defaultColour)
    : device_(device), headroom_(std::max(1.0, headroom)), defaultColour_(defaultColour) {
  drawCommand_ = device.createBuffer(kCommandBytes, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
}

MeshView IncrementalDrawBuffers::view() const {
  MeshView v;
  v.positions = positions_.handle();
  v.normals = normals_.handle();
  v.colours = colours_.handle();
  v.indices = indices_.handle();
  v.indirect = drawCommand_.handle();
  return v;
}

DrawPatchStats IncrementalDrawBuffers::record(Recorder& rec, const mesh::TriMesh& m, ChangedRange vertices,
                                              ChangedRange triangles) {
  const std::uint64_t nv = m.positions.size(), nt = m.triangles.size();
  if (m.normals.size() != nv) throw VulkanError("incremental draw buffers: the mesh has no normals");
  if (!m.colours.empty() && m.colours.size() != nv) throw VulkanError("incremental draw buffers: colours and positions differ in count");
  DrawPatchStats st;
  st.inPlace = filled_ && nv <= vertexCapacity_ && nt <= triangleCapacity_;
  if (!st.inPlace) {  // new buffers, filled whole
    vertexCapacity_ = std::max<std::uint64_t>(std::uint64_t(std::ceil(double(nv) * headroom_)), 1);
    triangleCapacity_ = std::max<std::uint64_t>(std::uint64_t(std::ceil(double(nt) * headroom_)), 1);
    positions_ = device_.createBuffer(vertexCapacity_ * 12, MemoryUse::DeviceLocal, kDrawUsage);
    normals_ = device_.createBuffer(vertexCapacity_ * 12, MemoryUse::DeviceLocal, kDrawUsage);
    colours_ = device_.createBuffer(vertexCapacity_ * 12, MemoryUse::DeviceLocal, kDrawUsage);
    indices_ = device_.createBuffer(triangleCapacity_ * 12, MemoryUse::DeviceLocal, kDrawUsage);
    vertices = {0, nv};
    triangles = {0, nt};
    filled_ = true;
  }
  vertices.to = std::min(vertices.to, nv);
  triangles.to = std::min(triangles.to, nt);
  const std::uint64_t v0 = std::min(vertices.from, vertices.to), vn = vertices.to - v0;
  const std::uint64_t t0 = std::min(triangles.from, triangles.to), tn = triangles.to - t0;

  const std::uint32_t command[5] = {std::uint32_t(3 * nt), 1, 0, 0, 0};
  std::vector<Piece> pieces;
  if (vn) {
    pieces.push_back({&positions_, v0 * 12, vn * 12, m.positions.data() + v0});
    pieces.push_back({&normals_, v0 * 12, vn * 12, m.normals.data() + v0});
    pieces.push_back({&colours_, v0 * 12, vn * 12, m.colours.empty() ? nullptr : m.colours.data() + v0});
  }
  if (tn) pieces.push_back({&indices_, t0 * 12, tn * 12, m.triangles.data() + t0});
  pieces.push_back({&drawCommand_, 0, kCommandBytes, command});

  std::uint64_t total = 0;
  for (const Piece& p : pieces) total += (p.bytes + 15) / 16 * 16;
  if (staging_.size() < total) staging_ = device_.createBuffer(total, MemoryUse::Upload);
  char* mapped = static_cast<char*>(staging_.mapped());
  if (!mapped) throw VulkanError("incremental draw buffers: the staging buffer is not host visible");
  std::uint64_t at = 0;
  for (const Piece& p : pieces) {
    if (p.from) {
      std::memcpy(mapped + at, p.from, p.bytes);
    } else {
      for (std::uint64_t i = 0; i < p.bytes / 12; ++i) std::memcpy(mapped + at + 12 * i, defaultColour_.data(), 12);
    }
    rec.copy(staging_, at, *p.to, p.offset, p.bytes);
    at += (p.bytes + 15) / 16 * 16;
    st.bytesCopied += p.bytes;
  }
  // The copies' writes, visible to the draw's vertex input and indirect command read.
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDEX_READ_BIT |
                          VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT;
  device_.d().vkCmdPipelineBarrier(rec.cmd(), VK_PIPELINE_STAGE_TRANSFER_BIT,
                                   VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT |
                                       VK_PIPELINE_STAGE_TRANSFER_BIT,
                                   0, 1, &barrier, 0, nullptr, 0, nullptr);
  return st;
}

}  // namespace blobvk::vk
