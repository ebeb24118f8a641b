#include "blobvk/vk/extract/scan.h"

#include <array>

namespace blobvk::vk {

std::uint64_t scanScratchWords(std::uint64_t count) {
  if (count <= kScanChunk) return 0;
  const std::uint64_t blocks = (count + kScanChunk - 1) / kScanChunk;
  return blocks + scanScratchWords(blocks);
}

void recordExclusiveScan(Recorder& rec, VkBuffer values, std::uint32_t valueOffset,
                         std::uint32_t count, VkBuffer scratch, std::uint32_t scratchOffset,
                         VkBuffer totals, std::uint32_t totalIndex) {
  Device& dev = rec.device();
  const std::array<std::uint32_t, 1> spec{kScanWorkgroup};
  const KernelPtr reduce = dev.kernel("scan_reduce", spec);
  const KernelPtr apply = dev.kernel("scan_apply", spec);
  const std::uint32_t blocks = (count + kScanChunk - 1) / kScanChunk;
  if (blocks <= 1) {
    const std::uint32_t push[5] = {valueOffset, count, 0u, 0u, totalIndex};
    const BufferRange bind[3] = {{values, 0, VK_WHOLE_SIZE},
                                 {scratch ? scratch : totals, 0, VK_WHOLE_SIZE},
                                 {totals, 0, VK_WHOLE_SIZE}};
    rec.dispatch(*apply, bind, push, sizeof(push), 1);
    return;
  }
  const Groups g = groupsFor(blocks, kScanWorkgroup);
  {
    const std::uint32_t push[3] = {valueOffset, count, scratchOffset};
    const BufferRange bind[2] = {{values, 0, VK_WHOLE_SIZE}, {scratch, 0, VK_WHOLE_SIZE}};
    rec.dispatch(*reduce, bind, push, sizeof(push), g.x, g.y);
  }
  rec.computeBarrier();
  recordExclusiveScan(rec, scratch, scratchOffset, blocks, scratch, scratchOffset + blocks, totals,
                      totalIndex);
  rec.computeBarrier();
  {
    const std::uint32_t push[5] = {valueOffset, count, scratchOffset, 1u, ~0u};
    const BufferRange bind[3] = {{values, 0, VK_WHOLE_SIZE},
                                 {scratch, 0, VK_WHOLE_SIZE},
                                 {totals, 0, VK_WHOLE_SIZE}};
    rec.dispatch(*apply, bind, push, sizeof(push), g.x, g.y);
  }
}

}  // namespace blobvk::vk
