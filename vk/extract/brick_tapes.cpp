#include "blobvk/vk/extract/brick_tapes.h"

#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/region_tape.h"

#include <algorithm>
#include <cstring>
#include <unordered_map>

namespace blobvk::vk {
namespace {

constexpr std::uint32_t kLog2BlockBricks = 2;  // blocks of 4 x 4 x 4 bricks

// FNV-1a over a tape's words.
std::uint64_t tapeHash(std::span<const layout::Instruction> tape) {
  std::uint64_t h = 1469598103934665603ull;
  for (const layout::Instruction& in : tape) {
    const std::uint32_t w[4] = {in.code.x, in.code.y, in.code.z, in.code.w};
    for (std::uint32_t v : w) h = (h ^ v) * 1099511628211ull;
  }
  return h;
}

// Whether the stored tape at `begin` (absolute targets) is `tape` (relative targets).
bool sameTape(std::span<const layout::Instruction> stored, std::uint32_t begin,
              std::span<const layout::Instruction> tape) {
  for (std::size_t i = 0; i < tape.size(); ++i) {
    layout::uvec4 a = stored[i].code;
    const layout::uvec4& b = tape[i].code;
    if ((a.x & 0xffu) == layout::OP_SKIP) a.w -= begin;
    if (a.x != b.x || a.y != b.y || a.z != b.z || a.w != b.w) return false;
  }
  return true;
}

}  // namespace

void buildBrickTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                     std::span<const std::uint32_t> packedBricks, std::uint32_t emptyBox, BrickTapes& out) {
  out.code.clear();
  out.ranges.assign(packedBricks.size() * 2, 0);
  out.instructions = 0;
  const std::uint32_t B = 1u << bricks.log2B;
  // The block tapes, by packed block coordinates; bricks come in (z, y, x) order, so a block's
  // bricks are met in a few runs and its tape is reused.
  std::unordered_map<std::uint64_t, std::vector<layout::Instruction>> blocks;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> seen;  // tape hash -> begins (equal lengths too)
  std::vector<layout::Instruction> tape;
  for (std::size_t a = 0; a < packedBricks.size(); ++a) {
    const std::array<std::uint32_t, 3> b = bricks.unpack(packedBricks[a]);
    std::array<std::uint32_t, 3> block{}, lo{}, hi{};
    for (int i = 0; i < 3; ++i) block[i] = b[i] >> kLog2BlockBricks;
    const std::uint64_t key = block[0] | std::uint64_t(block[1]) << 21 | std::uint64_t(block[2]) << 42;
    auto [it, fresh] = blocks.try_emplace(key);
    if (fresh) {
      for (int i = 0; i < 3; ++i) {
        lo[i] = (block[i] << kLog2BlockBricks) * B;
        hi[i] = ((block[i] + 1) << kLog2BlockBricks) * B;  // every point its bricks' fields take
      }
      appendRegionTape(program.code, program, regionOfPoints(grid, lo, hi), emptyBox, TapeUse::Field, it->second);
    }
    for (int i = 0; i < 3; ++i) {
      lo[i] = b[i] * B;
      hi[i] = b[i] * B + B;
    }
    tape.clear();
    appendRegionTape(it->second, program, regionOfPoints(grid, lo, hi), emptyBox, TapeUse::Field, tape);
    out.instructions += tape.size();
    const std::uint64_t h = tapeHash(tape) ^ tape.size() * 0x9e3779b97f4a7c15ull;
    std::vector<std::uint32_t>& begins = seen[h];
    std::uint32_t begin = ~0u;
    for (std::uint32_t s : begins)
      if (s + tape.size() <= out.code.size() && sameTape(std::span(out.code).subspan(s, tape.size()), s, tape)) begin = s;
    if (begin == ~0u) {
      begin = std::uint32_t(out.code.size());
      for (layout::Instruction in : tape) {
        if ((in.code.x & 0xffu) == layout::OP_SKIP) in.code.w += begin;
        out.code.push_back(in);
      }
      begins.push_back(begin);
    }
    out.ranges[2 * a] = begin;
    out.ranges[2 * a + 1] = begin + std::uint32_t(tape.size());
  }
}

}  // namespace blobvk::vk
