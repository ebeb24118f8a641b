// Per-brick tapes for the sparse field pass: for each brick of a batch, the program pruned to the
// brick's points (vk/eval/region_tape.h, TapeUse::Field), which brick_field_tapes*.comp interpret.
//
// The tapes are built on the host per batch from the batch's brick list: each brick's from the
// tape of its block of 4 x 4 x 4 bricks, itself pruned from the program once (a walk of the
// program per brick would cost tower_L6P8I4's 6,448 instructions each), and equal tapes are
// stored once (bricks in the same primitives' reach share their code).
//
// Two packings. `BrickTapes`: every tape in one storage buffer beside the program's records.
// `UniformTapes`: the bricks cut into windows (runs of bricks in batch order) whose tapes, and the
// records those tapes use, fit uniform blocks of 64 KB, records renumbered within the window:
// llvmpipe reads a uniform block with a vector gather and a storage buffer with a loop over the
// lanes, so the interpreter runs several times faster from uniform blocks, and a program of any
// size (tower_L6P8I4's records are 425 KB) fits them once pruned to a window.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/region_tape.h"
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
// index of the empty skip box the evaluator sees (GpuProgram::emptyBox). Deterministic. `use`:
// the field pass's tapes, or TapeUse::Vertex for the vertex pass (brick_vertices_direct_tapes).
void buildBrickTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                     std::span<const std::uint32_t> packedBricks, std::uint32_t emptyBox, BrickTapes& out,
                     TapeUse use = TapeUse::Field);

// Records per uniform block of 64 KB (brick_field_tapes_uniform.comp's array lengths).
inline constexpr std::uint32_t kUniformTapeCode = 4096, kUniformTapePrims = 1024, kUniformTapeMatrices = 1365,
                               kUniformTapeBoxes = 2048, kUniformTapeWarps = 2048;
inline constexpr std::uint64_t kUniformTapeBlock = 65536;

struct UniformTapes {
  struct Window {
    std::uint32_t firstBrick = 0, endBrick = 0;  // batch bricks [first, end)
  };
  std::vector<Window> windows;
  // Window w's block of each array starts at w times the block's length (kUniformTape*); indices
  // in its code (records, skip targets) are the window's own. Box 0 of every window is empty.
  std::vector<layout::Instruction> code;
  std::vector<layout::PrimitiveRecord> primitives;
  std::vector<layout::MatrixRecord> matrices;
  std::vector<layout::BoxRecord> boxes;
  std::vector<layout::WarpRecord> warps;
  std::vector<std::uint32_t> ranges;  // per brick: first instruction and end, in its window
  std::uint64_t instructions = 0;
};

// The same tapes packed in windows for uniform blocks; false (out unspecified) when one brick's
// tape alone is over a block (then buildBrickTapes' storage buffers serve). With TapeUse::Vertex
// the vertex tapes (brick_vertices_direct_tapes_uniform, a dispatch per window).
bool buildUniformTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                       std::span<const std::uint32_t> packedBricks, UniformTapes& out, TapeUse use = TapeUse::Field);

}  // namespace blobvk::vk
