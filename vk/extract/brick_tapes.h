// Per-brick tapes for the sparse field pass: for each brick of a batch, the program pruned to the
// brick's points (vk/eval/region_tape.h, TapeUse::Field), which brick_field_tapes.comp interprets.
//
// The tapes are built on the host per batch from the batch's brick list: each brick's from the
// tape of its block of 4 x 4 x 4 bricks, itself pruned from the program once (a walk of the
// program per brick would cost tower_L6P8I4's 6,448 instructions each), and equal tapes are
// stored once (bricks in the same primitives' reach share their code).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::vk {

struct BrickTapes {
  // Every distinct tape, one after the other; skip targets are absolute (indices into `code`).
  std::vector<layout::Instruction> code;
  // Per brick of the list: its tape's first instruction and its end (2 words a brick).
  std::vector<std::uint32_t> ranges;
  std::uint64_t instructions = 0;  // sum of the bricks' tape lengths (what the field pass runs per point)
};

// The tapes of `packedBricks` (BrickGrid::pack, in batch order) over `grid`. `emptyBox` is the
// index of the empty skip box the evaluator sees (GpuProgram::emptyBox). Deterministic.
void buildBrickTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                     std::span<const std::uint32_t> packedBricks, std::uint32_t emptyBox, BrickTapes& out);

}  // namespace blobvk::vk
