// Per-region tape pruning (as libfive and Fidget do): the Program's code specialised to the
// points of one box, e.g. an MPU. The result is an ordinary Program (same records, new code
// using only the existing opcodes), so every evaluator runs it, and it gives the same field
// bits as the full Program at every point of the box:
//  - an OP_SKIP whose box misses the region is resolved to "register = 0" (the subtree is
//    dropped); one whose box contains the region loses its test;
//  - (field tapes only) a primitive that is exactly 0 over the region is a constant 0, and
//    constants fold through operators only by identities that are bitwise exact for the other
//    operand's possible values: a + 0 and max(a, 0) for a >= 0 that is never -0 or NaN (tracked
//    per register), a * 1, a * (1 - 0), min(a, 0) = 0 for such a. Colour tapes keep every
//    operator (colour blending is not exact under these identities): they resolve skips and
//    replace a primitive that is 0 over the region by its null twin (an unknown primitive type,
//    exactly 0 in every evaluator, with the same colour and no matrix).
// A constant that must exist at run time is written by an OP_SKIP on an empty box (0; then
// OP_ONE_MINUS for 1). Dropping the first operand of a combine renames the second operand's
// register in its code (Sethi-Ullman code keeps a subtree's registers at or above its own).
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

namespace blobvk::cpu {

enum class TapeUse { Field, FieldColour };

// A copy of `program` with one extra, empty box that pruned tapes use to write a constant 0,
// and a null twin after the records of every primitive (index + program.primitives.size()).
// specialiseTape() only rewrites `code`, so one such copy per thread serves every region.
blobtree::Program makeTapeProgram(const blobtree::Program& program);

// tape.code = program.code specialised to points p with lo <= p <= hi (world coordinates; the
// box is padded for float rounding inside). `tape` must come from makeTapeProgram(program).
void specialiseTape(const blobtree::Program& program, const glm::dvec3& lo, const glm::dvec3& hi,
                    TapeUse use, blobtree::Program& tape);

// Both tapes of one region in one go (each primitive's bound is computed once for the two).
void specialiseTapes(const blobtree::Program& program, const glm::dvec3& lo,
                     const glm::dvec3& hi, blobtree::Program& fieldTape,
                     blobtree::Program* colourTape);

}  // namespace blobvk::cpu
