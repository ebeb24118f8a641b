// A whole program's code and records in five uniform blocks of 64 KB, for the kernels that read
// them there (brick_classify_uniform.comp; EVAL_RECORDS_UNIFORM: brick_vertices_direct_uniform.comp).
//
// Why: llvmpipe reads a uniform block with a vector gather, a storage buffer with a loop over the
// lanes, a branch per lane and component. The interpreter loads a record per instruction, so the
// classification and the vertex pass that interprets the gradient (a first job, before the
// generated gradient is built) spend most of their time in those loops.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"

#include <cstdint>
#include <vector>

namespace blobvk::vk {

inline constexpr std::uint64_t kUniformProgramBlock = 65536;

// Whether each of `program`'s record arrays (its boxes with the empty skip box after them) fits
// a block: at most 4,096 instructions, 1,024 primitives, 1,365 matrices, 2,047 boxes, 2,048 warps.
bool fitsUniformBlocks(const blobtree::Program& program);

// The blocks in shader order (code, primitives, matrices, boxes, warps), each of
// kUniformProgramBlock bytes with the records at its start (what follows them is never read); the boxes end with the empty skip box
// uploadProgram appends (GpuProgram::emptyBox). Empty where the program does not fit them or
// the device binds smaller uniform ranges: the kernels then read the storage buffers.
std::vector<Buffer> uploadUniformProgram(Device& device, const blobtree::Program& program);

}  // namespace blobvk::vk
