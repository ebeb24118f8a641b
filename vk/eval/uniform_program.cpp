#include "blobvk/vk/eval/uniform_program.h"

#include "blobvk/vk/eval/region_tape.h"

#include <utility>

namespace blobvk::vk {

bool fitsUniformBlocks(const blobtree::Program& program) {
  // The blocks' array lengths (eval_program.glsl, EVAL_RECORDS_UNIFORM): whole records of each size.
  auto fits = [](std::size_t records, std::size_t bytes) { return records * bytes <= kUniformProgramBlock; };
  return fits(program.code.size(), sizeof(program.code[0])) &&
         fits(program.primitives.size(), sizeof(program.primitives[0])) &&
         fits(program.matrices.size(), sizeof(program.matrices[0])) &&
         fits(program.boxes.size() + 1, sizeof(layout::BoxRecord)) &&
         fits(program.warps.size(), sizeof(program.warps[0]));
}

std::vector<Buffer> uploadUniformProgram(Device& device, const blobtree::Program& program) {
  std::vector<Buffer> blocks;
  if (device.info().limits.maxUniformBufferRange < kUniformProgramBlock || !fitsUniformBlocks(program)) return blocks;
  std::vector<layout::BoxRecord> boxes = program.boxes;
  boxes.push_back(emptySkipBox());
  const std::pair<const void*, std::uint64_t> records[5] = {
      {program.code.data(), program.code.size() * sizeof(program.code[0])},
      {program.primitives.data(), program.primitives.size() * sizeof(program.primitives[0])},
      {program.matrices.data(), program.matrices.size() * sizeof(program.matrices[0])},
      {boxes.data(), boxes.size() * sizeof(boxes[0])},
      {program.warps.data(), program.warps.size() * sizeof(program.warps[0])}};
  for (const auto& r : records) {
    blocks.push_back(device.createBuffer(kUniformProgramBlock, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));
    if (r.second) device.upload(blocks.back(), r.first, r.second);
  }
  return blocks;
}

}  // namespace blobvk::vk
