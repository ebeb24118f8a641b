// The sparse extraction's brick classification bound (shaders/brick_classify_body.glsl) as
// generated straight-line GLSL: the Program's register code spelled out, replacing the
// interpreter of shaders/brick_classify_bounds.glsl.
//
// Why: llvmpipe has no real branches, so the interpreter runs every opcode's code (every
// primitive type's skeleton box, the warps, the skip bookkeeping) and indexes its register array
// per lane for every instruction; the generated code runs one instruction's helper each, with
// registers as plain variables. It calls the very helpers the interpreter calls with the same
// records, loaded from the same uniform buffers at literal indices (record values are never
// literals, so nothing folds differently): the bound is the interpreter's, bit for bit.
// Skips run masked: the region always runs, and where the box missed, the registers it wrote
// take back their values (the skip's own register 0), as the interpreter's jump leaves them.
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstdint>
#include <string>

namespace blobvk::vk {

// Beyond this many instructions glslang and llvmpipe take seconds to build the kernel, more than
// the classification it saves on any grid blobvk meshes (and the interpreter's records no longer
// fit its uniform blocks past 4,096 instructions).
inline constexpr std::size_t kMaxIntervalInstructions = 2048;

// Skips over at least this many instructions branch: a loop the lanes' vector leaves when all
// its lanes missed the box (llvmpipe leaves loops, but runs both sides of an `if`); shorter ones
// run masked.
inline constexpr std::size_t kIntervalBranchInstructions = 3;

// Straight-line runs are cut into blocks of at most this many instructions (see the .cpp).
inline constexpr std::size_t kIntervalBlockInstructions = 8;

// True when generateIntervalBounds gives the interpreter's bound exactly: at most
// kMaxIntervalInstructions, record indices in range, skips that jump forward within the code
// and nest, and at most MAX_PENDING (16) skips nested (past it the interpreter gives up at run
// time, which straight-line code does not mirror).
bool canGenerateIntervalBounds(const blobtree::Program& program);

// A fingerprint of what the generated code depends on: the instructions and the primitives' and
// warps' type words (the records' values are read at run time, so edits that move primitives
// keep the kernel).
std::uint64_t intervalBoundsFingerprint(const blobtree::Program& program);

// The text of brick_classify_bounds.glsl for this program: fieldBounds(Box, out bool). Throws
// std::invalid_argument when !canGenerateIntervalBounds.
std::string generateIntervalBounds(const blobtree::Program& program);

}  // namespace blobvk::vk
