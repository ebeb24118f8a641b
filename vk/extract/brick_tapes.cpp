#include "blobvk/vk/extract/brick_tapes.h"

#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/region_tape.h"

#include <algorithm>
#include <tuple>
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
                  std::uint32_t emptyBox, TapeUse use = TapeUse::Field)
      : program_(program), grid_(grid), bricks_(bricks), emptyBox_(emptyBox), use_(use) {}

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
      appendRegionTape(program_.code, program_, regionOfPoints(grid_, lo, hi), emptyBox_, use_, it->second);
    }
    for (int i = 0; i < 3; ++i) {
      lo[i] = b[i] * B;
      hi[i] = b[i] * B + B;
    }
    tape_.clear();
    appendRegionTape(it->second, program_, regionOfPoints(grid_, lo, hi), emptyBox_, use_, tape_);
    return tape_;
  }

 private:
  const blobtree::Program& program_;
  const blobtree::GridSpec& grid_;
  const BrickGrid& bricks_;
  std::uint32_t emptyBox_;
  TapeUse use_;
  // Block tapes by packed block coordinates; bricks come in (z, y, x) order, so a block's bricks
  // are met in a few runs and its tape is reused.
  std::unordered_map<std::uint64_t, std::vector<layout::Instruction>> blocks_;
  std::vector<layout::Instruction> tape_;
};

// Equal tapes stored once: by hash, the first instructions of the tapes with that hash.
class TapeStore {
 public:
  explicit TapeStore(std::vector<layout::Instruction>& code) : code_(code) {}
  // Where `tape` (relative targets) starts in the code, appended (targets counted from the
  // code's start) when not there yet.
  std::uint32_t place(std::span<const layout::Instruction> tape) {
    std::vector<std::uint32_t>& begins = seen_[tapeHash(tape)];
    for (std::uint32_t s : begins)
      if (sameTape(code_, s, tape)) return s;
    const std::uint32_t begin = std::uint32_t(code_.size());
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
                     std::span<const std::uint32_t> packedBricks, std::uint32_t emptyBox, BrickTapes& out,
                     TapeUse use) {
  out.code.clear();
  out.ranges.assign(packedBricks.size() * 2, 0);
  out.instructions = 0;
  BrickTapeWalker walker(program, grid, bricks, emptyBox, use);
  TapeStore store(out.code);
  for (std::size_t a = 0; a < packedBricks.size(); ++a) {
    const std::vector<layout::Instruction>& tape = walker.tapeOf(packedBricks[a]);
    out.instructions += tape.size();
    const std::uint32_t begin = store.place(tape);
    out.ranges[2 * a] = begin;
    out.ranges[2 * a + 1] = begin + std::uint32_t(tape.size());
  }
}

namespace {

// One record array's renumbering within a window: each program record's index in the window
// (kNone: not in it yet), the records given one (to reset them), and the window's block of
// `out`, which starts at window * capacity.
template <class Record>
struct Renumbering {
  std::vector<std::uint32_t> local;
  std::vector<std::uint32_t> given;
  std::vector<Record>* out = nullptr;
  std::uint32_t capacity = 0, count = 0;
  std::size_t base = 0;

  Renumbering(std::size_t records, std::vector<Record>& o, std::uint32_t c) : local(records, kNone), out(&o), capacity(c) {}
  // Window w's block, its first `reserved` records set by the caller.
  void open(std::size_t w, std::uint32_t reserved) {
    for (std::uint32_t i : given) local[i] = kNone;
    given.clear();
    out->resize((w + 1) * capacity);
    base = w * capacity;
    count = reserved;
  }
  // Record i's index in the window, `value` stored there if it is new; false when the block is full.
  bool intern(std::uint32_t i, const Record& value, std::uint32_t& index) {
    if (local[i] == kNone) {
      if (count == capacity) return false;
      local[i] = count;
      given.push_back(i);
      (*out)[base + count++] = value;
    }
    index = local[i];
    return true;
  }
  struct Mark {
    std::size_t given;
    std::uint32_t count;
  };
  Mark mark() const { return {given.size(), count}; }
  void undo(const Mark& m) {
    for (std::size_t i = m.given; i < given.size(); ++i) local[given[i]] = kNone;
    given.resize(m.given);
    count = m.count;
  }
};

// One window's renumbering of the program's records, and its code.
class WindowRecords {
 public:
  WindowRecords(const blobtree::Program& program, UniformTapes& out)
      : program_(program), out_(out), prims_(program.primitives.size(), out.primitives, kUniformTapePrims),
        matrices_(program.matrices.size(), out.matrices, kUniformTapeMatrices),
        boxes_(program.boxes.size(), out.boxes, kUniformTapeBoxes),
        warps_(program.warps.size(), out.warps, kUniformTapeWarps) {}

  // Starts window w: its blocks, the identity matrix at 0 (matrix 0 of every program) and the
  // empty box at 0.
  void open(std::size_t w) {
    out_.code.resize((w + 1) * kUniformTapeCode);
    prims_.open(w, 0);
    matrices_.open(w, 1);
    boxes_.open(w, 1);
    warps_.open(w, 0);
    code_.clear();
    out_.matrices[w * kUniformTapeMatrices] = program_.matrices.empty() ? layout::MatrixRecord{} : program_.matrices[0];
    out_.boxes[w * kUniformTapeBoxes] = emptySkipBox();
  }

  // `tape` (relative targets, the program's indices, `emptyBox` for 0) renumbered into `local`;
  // false, with the window unchanged, when its records would not fit.
  bool localise(std::span<const layout::Instruction> tape, std::uint32_t emptyBox,
                std::vector<layout::Instruction>& local) {
    const auto marks = std::make_tuple(prims_.mark(), matrices_.mark(), boxes_.mark(), warps_.mark());
    local.assign(tape.begin(), tape.end());
    bool fits = true;
    for (layout::Instruction& in : local) {
      const std::uint32_t op = in.code.x & 0xffu;
      if (op == layout::OP_PRIM || op == layout::OP_NULL_ADDS) {  // a null addition's: for its colour
        layout::PrimitiveRecord r = program_.primitives[in.code.y];
        fits = matrix(r.meta.y) && prims_.intern(in.code.y, r, in.code.y);
      } else if (op == layout::OP_SKIP && in.code.y == emptyBox) {
        in.code.y = 0;
      } else if (op == layout::OP_SKIP) {
        fits = boxes_.intern(in.code.y, program_.boxes[in.code.y], in.code.y);
      } else if (op == layout::OP_WARP) {
        layout::WarpRecord r = program_.warps[in.code.y];
        fits = matrix(r.meta.w) && warps_.intern(in.code.y, r, in.code.y);
      }
      if (!fits) break;
    }
    if (fits) return true;
    prims_.undo(std::get<0>(marks));
    matrices_.undo(std::get<1>(marks));
    boxes_.undo(std::get<2>(marks));
    warps_.undo(std::get<3>(marks));
    return false;
  }

  std::vector<layout::Instruction>& code() { return code_; }

 private:
  // Matrix index m renumbered in place (0, the identity, stays 0).
  bool matrix(std::uint32_t& m) { return m == 0 || matrices_.intern(m, program_.matrices[m], m); }

  const blobtree::Program& program_;
  UniformTapes& out_;
  Renumbering<layout::PrimitiveRecord> prims_;
  Renumbering<layout::MatrixRecord> matrices_;
  Renumbering<layout::BoxRecord> boxes_;
  Renumbering<layout::WarpRecord> warps_;
  std::vector<layout::Instruction> code_;  // the window's code so far (targets from its start)
};

}  // namespace

bool buildUniformTapes(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                       std::span<const std::uint32_t> packedBricks, UniformTapes& out, TapeUse use) {
  // Cleared, not freed: a runner reuses one UniformTapes for every batch, so its blocks' memory
  // is allocated (and faulted in) once.
  out.windows.clear();
  out.code.clear();
  out.primitives.clear();
  out.matrices.clear();
  out.boxes.clear();
  out.warps.clear();
  out.instructions = 0;
  out.ranges.assign(packedBricks.size() * 2, 0);
  const std::uint32_t emptyBox = std::uint32_t(program.boxes.size());
  BrickTapeWalker walker(program, grid, bricks, emptyBox, use);
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
      store.clear();
      if (!records.localise(tape, emptyBox, local) || local.size() > kUniformTapeCode) return false;
    }
    const std::uint32_t begin = store.place(local);
    out.ranges[2 * a] = begin;
    out.ranges[2 * a + 1] = begin + std::uint32_t(local.size());
  }
  flush();
  out.windows.back().endBrick = std::uint32_t(packedBricks.size());
  return true;
}

}  // namespace blobvk::vk
