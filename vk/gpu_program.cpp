#include "vk/gpu_program.h"

#include "vk/stack_program.h"

#include <stdexcept>
#include <string>

namespace blobvk::vk {
namespace {
template <class T>
Buffer uploadArray(Device& device, const std::vector<T>& v) {
  Buffer b = device.createBuffer(std::max<std::size_t>(v.size(), 1) * sizeof(T));
  device.upload(b, v.data(), v.size() * sizeof(T));
  return b;
}
}  // namespace

GpuProgram uploadProgram(Device& device, const blobtree::Program& program, Traversal traversal) {
  if (program.fieldRegisters > layout::MAX_FIELD_REGISTERS ||
      program.pointRegisters > layout::MAX_POINT_REGISTERS) {
    throw std::invalid_argument("Program needs " + std::to_string(program.fieldRegisters) +
                                " field and " + std::to_string(program.pointRegisters) +
                                " point registers, above the shader's register file");
  }
  GpuProgram g;
  if (traversal == Traversal::StackBased) {
    const auto tree = buildStackProgram(program);
    g.code = uploadArray(device, tree);
    g.codeLength = std::uint32_t(tree.size());
  } else {
    g.code = uploadArray(device, program.code);
    g.codeLength = std::uint32_t(program.code.size());
  }
  g.primitives = uploadArray(device, program.primitives);
  g.matrices = uploadArray(device, program.matrices);
  g.boxes = uploadArray(device, program.boxes);
  g.warps = uploadArray(device, program.warps);
  return g;
}

}  // namespace blobvk::vk
