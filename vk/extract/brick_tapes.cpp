#include "blobvk/vk/extract/brick_tapes.h"

#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/region_tape.h"

#include <algorithm>
#include <unordered_map>

namespace blobvk::vk {
namespace {

constexpr std::uint32_t kLog2BlockBricks = 2;  // blocks of 4 x 4 x 4 bricks
constexpr std::uint32_t kNone = ~0u;

bool isSkip(const layout::Instruction& in) { return (in.code.x & 0xffu) == layout::OP_SKIP; }

// FNV-1a over a tape's words, and its length.
std::uint64_t tapeHash(std::span<const layout::Instruction> tape) {
  std::uint64_t h = 1469598103934665603ull ^ tape.size();
  for (const layout::Instruction& in : tape) {
    const std::uint32_t w[4] = {in.code.x, in.code.y, in.code.z, in.code.w};
    for (std::uint32_t v : w) h = (h ^ v) * 1099511628211ull;
  }
  return h;
}

// Whether the stored code at `begin` (skip targets counted from the code's start) is `tape`
// (skip targets relative to its first instruction).
bool sameTape(std::span<const layout::Instruction> code, std::uint32_t begin, std::span<const layout::Instruction> tape) {
  if (begin + tape.size() > code.size()) return false;
  for (std::size_t i = 0; i < tape.size(); ++i) {
    layout::uvec4 a = code[begin + i].code;
    const layout::uvec4& b = tape[i].code;
    if ((a.x & 0xffu) == layout::OP_SKIP) a.w -= begin;
    if (a.x != b.x || a.y != b.y || a.z != b.z || a.w != b.w) return false;
  }
  return true;
}

// Each brick's tape in turn (skip targets relative, the program's record indices), pruned from
// its block's tape.
class BrickTapeWalker {
 public:
  BrickTapeWalker(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                  std::uint32_t emptyBox)
      : program_(program), grid_(grid), bricks_(bricks), emptyBox_(emptyBox) {}

  const std::vector<layout::Instruction>& tapeOf(std::uint32_t packed) {
    const std::uint32_t B = 1u << bricks_.log2B;
    const std::array<std::uint32_t, 3> b = bricks_.unpack(packed);
    std::array<std::uint32_t, 3> block{}, lo{}, hi{};
    for (int i = 0; i < 3; ++i) block[i] = b[i] >> kLog2BlockBricks;
    const std::uint64_t key = block[0] | std::uint64_t(block[1]) << 21 | std::uint64_t(block[2]) << 42;
    auto [it, fresh] = blocks_.try_emplace(key);
    if (fresh) {
      for (int i = 0; i < 3; ++i) {
        lo[i] = (block[i] << kLog2BlockBricks) * B;
        hi[i] = ((block[i] + 1) << kLog2BlockBricks) * B;  // every point its bricks' fields take
      }
      appendRegionTape(program_.code, program_, regionOfPoints(grid_, lo, hi), emptyBox_, TapeUse::Field, it->second);
    }
    for (int i = 0; i < 3; ++i) {
      lo[i] = b[i] * B;
      hi[i] = b[i] * B + B;
    }
    tape_.clear();
    appendRegionTape(it->second, program_, regionOfPoints(grid_, lo, hi), emptyBox_, TapeUse::Field, tape_);
    return tape_;
  }

 private:
  const blobtree::Program& program_;
  const blobtree::GridSpec& grid_;
  const BrickGrid& bricks_;
  std::uint32_t emptyBox_;
  // Block tapes by packed block coordinates; bricks come in (z, y, x) order, so a block's bricks
  // are met in a few runs and its tape is reused.
  std::unordered_map<std::uint64_t, std::vector<layout::Instruction>> blocks_;
  std::vector<layout::Instruction> tape_;
};

// Equal tapes stored once: by hash, the first instructions of the tapes with that hash.
class TapeStore {
 public:
  explicit TapeStore(std::vector<layout::Instruction>& code) : code_(code) {}
  // Where `tape` (relative targets) starts in the code from `base` on, appended (targets
  // counted from `base`) when not there yet.
  std::uint32_t place(std::span<const layout::Instruction> tape, std::size_t base) {
    std::vector<std::uint32_t>& begins = seen_[tapeHash(tape)];
    const std::span<const layout::Instruction> window(code_.data() + base, code_.size() - base);
    for (std::uint32_t s : begins)
      if (sameTape(window, s, tape)) return s;
    const std::uint32_t begin = std::uint32_t(code_.size() - base);
    for (layout::Instruction in : tape) {
      if (isSkip(in)) in.code.w += begin;
      code_.push_back(in);
    }
    begins.push_back(begin);
    return begin;
  }
  void clear() { seen_.clear(); }

 private:
  std::vector<layout::Instruction>& code_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> seen_;
};

}  // namespace

void buildBrickTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                     std::span<const std::uint32_t> packedBricks, std::uint32_t emptyBox, BrickTapes& out) {
  out.code.clear();
  out.ranges.assign(packedBricks.size() * 2, 0);
  out.instructions = 0;
  BrickTapeWalker walker(program, grid, bricks, emptyBox);
  TapeStore store(out.code);
  for (std::size_t a = 0; a < packedBricks.size(); ++a) {
    const std::vector<layout::Instruction>& tape = walker.tapeOf(packedBricks[a]);
    out.instructions += tape.size();
    const std::uint32_t begin = store.place(tape, 0);
    out.ranges[2 * a] = begin;
    out.ranges[2 * a + 1] = begin + std::uint32_t(tape.size());
  }
}

namespace {

// One window's renumbering of the program's records: local index per program record (kNone:
// not in the window), and the window's own records.
class WindowRecords {
 public:
  WindowRecords(const blobtree::Program& program, UniformTapes& out)
      : program_(program), out_(out), prim_(program.primitives.size(), kNone),
        matrix_(program.matrices.size(), kNone), box_(program.boxes.size(), kNone),
        warp_(program.warps.size(), kNone) {}

  // Starts window w: its blocks, the identity matrix at 0 and the empty box at 0.
  void open(std::size_t w) {
    for (std::uint32_t i : touchedPrims_) prim_[i] = kNone;
    for (std::uint32_t i : touchedMatrices_) matrix_[i] = kNone;
    for (std::uint32_t i : touchedBoxes_) box_[i] = kNone;
    for (std::uint32_t i : touchedWarps_) warp_[i] = kNone;
    touchedPrims_.clear();
    touchedMatrices_.clear();
    touchedBoxes_.clear();
    touchedWarps_.clear();
    out_.code.resize((w + 1) * kUniformTapeCode);
    out_.primitives.resize((w + 1) * kUniformTapePrims);
    out_.matrices.resize((w + 1) * kUniformTapeMatrices);
    out_.boxes.resize((w + 1) * kUniformTapeBoxes);
    out_.warps.resize((w + 1) * kUniformTapeWarps);
    base_ = w;
    code_.clear();
    primCount_ = 0;
    matrixCount_ = 1;
    boxCount_ = 1;
    warpCount_ = 0;
    out_.matrices[w * kUniformTapeMatrices] = program_.matrices.empty() ? layout::MatrixRecord{} : program_.matrices[0];
    if (!program_.matrices.empty()) {
      matrix_[0] = 0;
      touchedMatrices_.push_back(0);
    }
    out_.boxes[w * kUniformTapeBoxes] = emptySkipBox();
  }

  // `tape` (relative targets, the program's indices, `emptyBox` for 0) renumbered into `local`;
  // false, with the window unchanged, when its records would not fit.
  bool localise(std::span<const layout::Instruction> tape, std::uint32_t emptyBox,
                std::vector<layout::Instruction>& local) {
    const Counts saved = counts();
    const std::size_t marks[4] = {touchedPrims_.size(), touchedMatrices_.size(), touchedBoxes_.size(),
                                  touchedWarps_.size()};
    local.assign(tape.begin(), tape.end());
    bool fits = true;
    for (layout::Instruction& in : local) {
      const std::uint32_t op = in.code.x & 0xffu;
      if (op == layout::OP_PRIM) {
        in.code.y = primitive(in.code.y, fits);
      } else if (op == layout::OP_SKIP) {
        in.code.y = in.code.y == emptyBox ? 0u : box(in.code.y, fits);
      } else if (op == layout::OP_WARP) {
        in.code.y = warp(in.code.y, fits);
      }
      if (!fits) break;
    }
    if (fits) return true;
    // Undo this tape's records.
    auto undo = [](std::vector<std::uint32_t>& map, std::vector<std::uint32_t>& touched, std::size_t mark) {
      for (std::size_t i = mark; i < touched.size(); ++i) map[touched[i]] = kNone;
      touched.resize(mark);
    };
    undo(prim_, touchedPrims_, marks[0]);
    undo(matrix_, touchedMatrices_, marks[1]);
    undo(box_, touchedBoxes_, marks[2]);
    undo(warp_, touchedWarps_, marks[3]);
    restore(saved);
    return false;
  }

  std::vector<layout::Instruction>& code() { return code_; }

 private:
  struct Counts {
    std::uint32_t prims, matrices, boxes, warps;
  };
  Counts counts() const { return {primCount_, matrixCount_, boxCount_, warpCount_}; }
  void restore(const Counts& c) {
    primCount_ = c.prims;
    matrixCount_ = c.matrices;
    boxCount_ = c.boxes;
    warpCount_ = c.warps;
  }
  std::uint32_t matrix(std::uint32_t m, bool& fits) {
    if (m == 0 || m >= matrix_.size()) return m == 0 ? 0u : m;
    if (matrix_[m] != kNone) return matrix_[m];
    if (matrixCount_ == kUniformTapeMatrices) {
      fits = false;
      return 0;
    }
    matrix_[m] = matrixCount_;
    touchedMatrices_.push_back(m);
    out_.matrices[base_ * kUniformTapeMatrices + matrixCount_] = program_.matrices[m];
    return matrixCount_++;
  }
  std::uint32_t primitive(std::uint32_t p, bool& fits) {
    if (prim_[p] != kNone) return prim_[p];
    if (primCount_ == kUniformTapePrims) {
      fits = false;
      return 0;
    }
    layout::PrimitiveRecord r = program_.primitives[p];
    r.meta.y = matrix(r.meta.y, fits);
    if (!fits) return 0;
    prim_[p] = primCount_;
    touchedPrims_.push_back(p);
    out_.primitives[base_ * kUniformTapePrims + primCount_] = r;
    return primCount_++;
  }
  std::uint32_t box(std::uint32_t b, bool& fits) {
    if (box_[b] != kNone) return box_[b];
    if (boxCount_ == kUniformTapeBoxes) {
      fits = false;
      return 0;
    }
    box_[b] = boxCount_;
    touchedBoxes_.push_back(b);
    out_.boxes[base_ * kUniformTapeBoxes + boxCount_] = program_.boxes[b];
    return boxCount_++;
  }
  std::uint32_t warp(std::uint32_t w, bool& fits) {
    if (warp_[w] != kNone) return warp_[w];
    if (warpCount_ == kUniformTapeWarps) {
      fits = false;
      return 0;
    }
    layout::WarpRecord r = program_.warps[w];
    r.meta.w = matrix(r.meta.w, fits);
    if (!fits) return 0;
    warp_[w] = warpCount_;
    touchedWarps_.push_back(w);
    out_.warps[base_ * kUniformTapeWarps + warpCount_] = r;
    return warpCount_++;
  }

  const blobtree::Program& program_;
  UniformTapes& out_;
  std::vector<std::uint32_t> prim_, matrix_, box_, warp_;
  std::vector<std::uint32_t> touchedPrims_, touchedMatrices_, touchedBoxes_, touchedWarps_;
  std::vector<layout::Instruction> code_;  // the window's code so far (targets from its start)
  std::size_t base_ = 0;
  std::uint32_t primCount_ = 0, matrixCount_ = 1, boxCount_ = 1, warpCount_ = 0;
};

}  // namespace

bool buildUniformTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                       std::span<const std::uint32_t> packedBricks, UniformTapes& out) {
  out = UniformTapes{};
  out.ranges.assign(packedBricks.size() * 2, 0);
  const std::uint32_t emptyBox = std::uint32_t(program.boxes.size());
  BrickTapeWalker walker(program, grid, bricks, emptyBox);
  WindowRecords records(program, out);
  TapeStore store(records.code());
  std::vector<layout::Instruction> local;
  auto flush = [&] {  // the open window's code into its block
    std::copy(records.code().begin(), records.code().end(), out.code.begin() + std::ptrdiff_t((out.windows.size() - 1) * kUniformTapeCode));
  };
  out.windows.push_back({0, 0});
  records.open(0);
  for (std::size_t a = 0; a < packedBricks.size(); ++a) {
    const std::vector<layout::Instruction>& tape = walker.tapeOf(packedBricks[a]);
    out.instructions += tape.size();
    bool fits = records.localise(tape, emptyBox, local) && records.code().size() + local.size() <= kUniformTapeCode;
    if (!fits) {  // a new window (the records this tape took stay: unused, harmless)
      if (out.windows.back().firstBrick == a) return false;  // alone over a block
      flush();
      out.windows.back().endBrick = std::uint32_t(a);
      out.windows.push_back({std::uint32_t(a), 0});
      records.open(out.windows.size() - 1);
      records.code().clear();
      store.clear();
      if (!records.localise(tape, emptyBox, local) || local.size() > kUniformTapeCode) return false;
    }
    const std::uint32_t begin = store.place(local, 0);
    out.ranges[2 * a] = begin;
    out.ranges[2 * a + 1] = begin + std::uint32_t(local.size());
  }
  flush();
  out.windows.back().endBrick = std::uint32_t(packedBricks.size());
  return true;
}

}  // namespace blobvk::vk
