// Tape pruning at run time: the register code of a Program cut down to what it computes at the
// points of one small region (a brick of the sparse extraction), for the interpreter.
//
// Why: the interpreter pays per instruction, whatever the instruction does (llvmpipe has no real
// branches: every opcode's case runs masked), and per-point box skips still cost their test and
// the instructions of every subtree a point is inside. The generated code's field tiles prune at
// compile time, but only a few tiles per job (each is a pipeline build); a brick's tape costs a
// host walk of the code and no build, so every brick gets the code of its own neighbourhood
// (random128: 256 instructions, a few tens per brick). This is the tape pruning of interval
// evaluation in GPU implicit renderers, done on the host from the boxes compile() already emits.
//
// A tape is register code like Program::code with skip targets relative to its first
// instruction; its records are the program's (the same primitive, matrix, box and warp indices),
// plus one box that holds no point (`emptyBox`, see below).
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::vk {

// What a tape may leave out, besides whole subtrees whose skip box misses the region and skips
// whose box holds the whole region (both exact: the same operations run on the same values).
enum class TapeUse {
  // The field alone (its value and whether it is >= the iso value): a primitive that is 0 in the
  // region becomes 0, and a 0 that is only added to another register disappears with its
  // addition. The field is the same float at every point of the region, but for the sign of a
  // zero (x + 0 is +0 where x is -0), which no comparison, interpolation or mask sees.
  Field,
  // Field, gradient and colour bit for bit (the vertex pass): only subtrees and skips go; a
  // primitive that is 0 in the region stays (its colour and the sign of its zero gradient can
  // still reach the result).
  Exact,
  // Exact, for the gradient interpreter of the sparse vertex pass: besides, a run of pairs (a
  // primitive that is 0 in the region into register b, OP_ADD of b into register a) is one
  // OP_NULL_ADDS with the pairs' bits (shaders/program_layout.h), as the generated gradient's
  // nullAdds folds them (a flat blend's points away from the region).
  Vertex,
};

// The box record every "write 0" of a tape tests against: lo above hi, so every point is outside
// it and an OP_SKIP on it writes 0 (colour and gradient 0) and jumps to the next instruction.
layout::BoxRecord emptySkipBox();

// Appends to `out` the tape of `tape` (relative skip targets; Program::code is one) over `region`
// and returns its length; `program` gives the records. Skip targets of the result are relative
// to its first instruction. `emptyBox` is the index of an emptySkipBox() record the evaluator
// will see (uploadProgram puts one after the program's boxes). Without a valid region the tape
// is copied.
std::uint32_t appendRegionTape(std::span<const layout::Instruction> tape, const blobtree::Program& program,
                               const PointRegion& region, std::uint32_t emptyBox, TapeUse use,
                               std::vector<layout::Instruction>& out);

// True when every point of the region lies inside the box (no point of it can take the skip).
bool regionInsideBox(const PointRegion& region, const layout::BoxRecord& box);

// True when `in` is an OP_PRIM on the world point whose primitive's support box misses the
// region: field +0 and gradient M^T (+0) at every point of it.
bool regionPrunesPrimitive(const blobtree::Program& program, const PointRegion& region, const layout::uvec4& in);

// The signs of such a pruned primitive's gradient, M^T (+0, +0, +0) as transposeTimesRows sums
// it: component j is -0 only where r0[j], r1[j] and r2[j] are all negative; bit j set: -0.
std::uint32_t prunedGradientNegativeZeros(const blobtree::Program& program, std::uint32_t primitive);

}  // namespace blobvk::vk
