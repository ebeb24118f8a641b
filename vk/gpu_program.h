// A Program uploaded to device buffers (the five record arrays of shaders/program_layout.h),
// bound at five consecutive bindings by every evaluating kernel.
#pragma once

#include "blobtree/program.h"
#include "vk/context.h"

#include <array>
#include <cstdint>

namespace blobvk::vk {

enum class Traversal {
  Stackless,   // the compiled register code with box skips (the thesis' stackless traversal)
  StackBased,  // a tree walk with an explicit node stack (Table 4.2's comparison)
};

struct GpuProgram {
  Buffer code, primitives, matrices, boxes, warps;
  std::uint32_t codeLength = 0;
  // The five bindings in shader order.
  std::array<BufferRange, 5> bindings() const {
    return {BufferRange(code), BufferRange(primitives), BufferRange(matrices), BufferRange(boxes),
            BufferRange(warps)};
  }
};

// Uploads the records; Traversal::StackBased uploads the tree encoding (stack_program.h) in
// place of the register code. Throws std::invalid_argument for a Program over the register
// limits of the layout.
GpuProgram uploadProgram(Device& device, const blobtree::Program& program,
                         Traversal traversal = Traversal::Stackless);

}  // namespace blobvk::vk
