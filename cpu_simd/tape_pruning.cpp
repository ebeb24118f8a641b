// See tape_pruning.h. One pass over the code, keeping per field register a static state
// (unknown, non-negative, or a known constant) and the output position where the code of its
// current value starts; a subtree's code is contiguous, so a dropped subtree is a truncation.
#include "blobvk/cpu_simd/tape_pruning.h"

#include "blobvk/blobtree/pow_field.h"
#include "blobvk/cpu_simd/field_bounds.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace blobvk::cpu {
namespace {

using layout::Instruction;

constexpr float kEmptyLo = 3e38f, kEmptyHi = -3e38f;
constexpr std::uint32_t kNullPrimitive = 0xffu;

// Nonneg: >= 0, never -0, never NaN (primitives, and sums/max/min/powers of such values).
enum class Kind : std::uint8_t { Unknown, Nonneg, Const };

struct Reg {
  Kind kind = Kind::Unknown;
  float c = 0.0f;         // the value when Const (always +0 or 1)
  std::size_t start = 0;  // where the code of the current value begins in the output
  // Colour tapes: the field is exactly +0 at every point of the region (null twins, constant 0,
  // combines of such). Then every combine keeps its first operand's field and colour per lane.
  bool zeroField = false;
};

struct OpenSkip {
  std::uint32_t inputTarget, dst;
  std::size_t skipAt, start;  // the emitted OP_SKIP, and where its subtree's code begins
};

bool isFoldable(float v) { return std::bit_cast<std::uint32_t>(v) == 0u || v == 1.0f; }

bool binaryOp(std::uint32_t op) {
  return op == layout::OP_ADD || op == layout::OP_MAX || op == layout::OP_MIN ||
         op == layout::OP_DIFF || op == layout::OP_SDIFF || op == layout::OP_MUL;
}

// The kernels' float semantics (std::max/std::min argument order included).
float foldBinary(std::uint32_t op, float a, float b) {
  switch (op) {
    case layout::OP_ADD: return a + b;
    case layout::OP_MAX: return std::max(a, b);
    case layout::OP_MIN: return std::min(a, b);
    case layout::OP_DIFF: return std::min(a, 1.0f - b);
    case layout::OP_SDIFF: return a * (1.0f - b);
    case layout::OP_MUL: return a * b;
    default: throw std::logic_error("foldBinary: not a binary opcode");
  }
}

class Pruner {
 public:
  Pruner(const blobtree::Program& program, const BoundsBox& region, bool fieldOnly,
         blobtree::Program& tape, std::vector<std::int8_t>& zeroMemo)
      : program_(program), fieldOnly_(fieldOnly), out_(tape.code), zeroMemo_(zeroMemo),
        emptyBox_(std::uint32_t(tape.boxes.size() - 1)) {
    if (tape.boxes.size() != program.boxes.size() + 1 || tape.boxes.back().lo.x != kEmptyLo ||
        tape.primitives.size() != 2 * program.primitives.size())
      throw std::invalid_argument("specialiseTape: the tape must come from makeTapeProgram");
    pts_[0] = padBounds(region);
  }

  void run() {
    out_.clear();
    const auto& code = program_.code;
    const std::size_t n = code.size();
    std::size_t pc = 0;
    for (;;) {
      while (!skips_.empty() && skips_.back().inputTarget <= pc) closeSkip();
      if (pc >= n) break;
      const Instruction in = code[pc];
      const std::uint32_t op = in.code.x & 0xffu, dst = in.code.x >> 8;
      if (op == layout::OP_SKIP) {
        pc = skip(in, dst) ? in.code.w : pc + 1;
        continue;
      }
      if (op == layout::OP_PRIM) {
        pc_ = pc;
        prim(in, dst);
      } else if (binaryOp(op)) {
        combine(in, op, dst, in.code.y);
      } else if (op == layout::OP_ONE_MINUS || op == layout::OP_POW) {
        unary(in, op, dst);
      } else if (op == layout::OP_WARP) {
        out_.push_back(in);
        pts_[dst] = warpBounds(program_, program_.warps[in.code.y], pts_[in.code.z]);
      } else {
        out_.push_back(in);
      }
      ++pc;
    }
    if (n > 0) materialise(0);
  }

 private:
  std::size_t takeStart() const { return out_.size(); }
  void push(std::uint32_t op, std::uint32_t dst, std::uint32_t y, std::uint32_t z,
            std::uint32_t w) {
    out_.push_back({{op | (dst << 8), y, z, w}});
  }
  // Drops the code from `at` on, except OP_WARP: a warp's point register serves its whole
  // subtree, whose end the code does not mark, so warps stay (a dead one costs little).
  void truncate(std::size_t at) {
    std::size_t kept = at;
    for (std::size_t i = at; i < out_.size(); ++i)
      if ((out_[i].code.x & 0xffu) == layout::OP_WARP) out_[kept++] = out_[i];
    out_.resize(std::min(kept, out_.size()));
  }
  void setConst(std::uint32_t r, float c, std::size_t start) {
    reg_[r] = {Kind::Const, c, start};
    if (!fieldOnly_) materialise(r);
  }
  bool isConst(std::uint32_t r, float c) const {
    return reg_[r].kind == Kind::Const &&
           std::bit_cast<std::uint32_t>(reg_[r].c) == std::bit_cast<std::uint32_t>(c);
  }
  // A constant register gets real code: 0 from a skip on the empty box, 1 as 1 - 0.
  void materialise(std::uint32_t r) {
    if (reg_[r].kind != Kind::Const) return;
    push(layout::OP_SKIP, r, emptyBox_, 0, std::uint32_t(out_.size() + 1));
    if (reg_[r].c == 1.0f) push(layout::OP_ONE_MINUS, r, 0, 0, 0);
    reg_[r].kind = Kind::Nonneg;
    reg_[r].zeroField = reg_[r].c != 1.0f;
  }
  // The code from `from` on computes register `oldReg`; make it compute `newReg` instead.
  void rename(std::size_t from, std::uint32_t oldReg, std::uint32_t newReg) {
    for (std::size_t i = from; i < out_.size(); ++i) {
      layout::uvec4& c = out_[i].code;
      const std::uint32_t op = c.x & 0xffu;
      if (op != layout::OP_WARP && (c.x >> 8) == oldReg) c.x = op | (newReg << 8);
      if (binaryOp(op) && c.y == oldReg) c.y = newReg;
    }
  }

  void prim(const Instruction& in, std::uint32_t dst) {
    const layout::PrimitiveRecord& p = program_.primitives[in.code.y];
    const std::size_t start = takeStart();
    // Per code position: both tapes of a region ask the same question of each primitive.
    std::int8_t& zero = zeroMemo_[pc_];
    if (zero < 0) zero = primitiveIsZeroOver(program_, p, pts_[in.code.z]) ? 1 : 0;
    if (zero) {
      if (fieldOnly_) {
        reg_[dst] = {Kind::Const, 0.0f, start};
        return;
      }
      // Colour tapes: the same field (+0) and colour from a null primitive that costs nothing.
      push(layout::OP_PRIM, dst, std::uint32_t(program_.primitives.size()) + in.code.y, 0, 0);
      reg_[dst] = {Kind::Nonneg, 0.0f, start, true};
      return;
    }
    out_.push_back(in);
    const bool negativeQuadric = p.meta.x == layout::PRIM_QUADRIC && !(p.p0.w >= 0.0f);
    reg_[dst] = {negativeQuadric ? Kind::Unknown : Kind::Nonneg, 0.0f, start};
  }

  // Returns true when the skip is resolved as taken (the caller jumps past the subtree).
  bool skip(const Instruction& in, std::uint32_t dst) {
    const layout::BoxRecord& b = program_.boxes[in.code.y];
    const BoundsBox& q = pts_[in.code.z];
    const bool disjoint = q.hi.x < b.lo.x || q.hi.y < b.lo.y || q.hi.z < b.lo.z ||
                          q.lo.x > b.hi.x || q.lo.y > b.hi.y || q.lo.z > b.hi.z;
    if (disjoint) {
      setConst(dst, 0.0f, takeStart());
      return true;
    }
    const bool contained = q.lo.x >= b.lo.x && q.lo.y >= b.lo.y && q.lo.z >= b.lo.z &&
                           q.hi.x <= b.hi.x && q.hi.y <= b.hi.y && q.hi.z <= b.hi.z;
    if (contained) return false;  // no point is outside: the test goes, the subtree stays
    const std::size_t start = takeStart();
    skips_.push_back({in.code.w, dst, out_.size(), start});
    push(layout::OP_SKIP, dst, in.code.y, in.code.z, 0);
    return false;
  }

  void closeSkip() {
    const OpenSkip s = skips_.back();
    skips_.pop_back();
    Reg& r = reg_[s.dst];
    if (isConst(s.dst, 0.0f)) {  // 0 inside the box and 0 outside: no code at all
      truncate(s.start);
      r.start = s.start;
      return;
    }
    materialise(s.dst);  // the skipped lanes need a real value to zero
    out_[s.skipAt].code.w = std::uint32_t(out_.size());
    r.start = s.start;  // zeroing some lanes keeps Nonneg (the zero is +0)
  }

  void unary(const Instruction& in, std::uint32_t op, std::uint32_t dst) {
    Reg& r = reg_[dst];
    if (r.kind == Kind::Const) {
      const float e = std::bit_cast<float>(in.code.w);
      const float v = op == layout::OP_ONE_MINUS ? 1.0f - r.c : blobtree::powField(r.c, e);
      if (isFoldable(v)) {
        r.c = v;
        return;
      }
      materialise(dst);
    }
    out_.push_back(in);
    r.zeroField = false;  // 1 - 0 and pow(0, 0) are 1
    // pow(x >= +0) is >= +0 and not NaN for the finite exponents compile() emits.
    if (op == layout::OP_ONE_MINUS || r.kind != Kind::Nonneg) r.kind = Kind::Unknown;
  }

  void combine(const Instruction& in, std::uint32_t op, std::uint32_t d, std::uint32_t y) {
    Reg& a = reg_[d];
    const Reg b = reg_[y];
    const std::size_t start = std::min(a.start, b.start);
    if (a.kind == Kind::Const && b.kind == Kind::Const) {
      const float v = foldBinary(op, a.c, b.c);
      if (isFoldable(v)) {
        truncate(start);
        a = {Kind::Const, v, start};
        return;
      }
    }
    // Colour tapes, both fields +0 everywhere: every combine leaves its first operand as it is,
    // field and colour, lane by lane (add: w = 0 keeps the colour; max/min/mul: 0 > 0 and
    // 0 < 0 are false; diff/sdiff: 1 - 0 < 0 is false; the field +0 + +0, max, min, +0 * +0,
    // min(+0, 1), +0 * 1 are +0). So the second operand's code goes; only when it comes last.
    if (!fieldOnly_ && a.zeroField && b.zeroField && b.start > a.start) {
      truncate(b.start);
      a.start = start;
      return;
    }
    const bool aNonneg = a.kind == Kind::Nonneg, bNonneg = b.kind == Kind::Nonneg;
    const bool aZero = isConst(d, 0.0f), bZero = isConst(y, 0.0f);
    switch (op) {
      case layout::OP_ADD:
      case layout::OP_MAX:
        // a + 0 == max(a, 0) == a, bit for bit, for a >= +0 (not -0, not NaN).
        if (bZero && aNonneg) return truncate(b.start);
        if (aZero && bNonneg) return takeSecond(d, y, b, start);
        break;
      case layout::OP_MIN:
        if ((bZero && aNonneg) || (aZero && bNonneg)) {
          truncate(start);
          a = {Kind::Const, 0.0f, start};
          return;
        }
        break;
      case layout::OP_SDIFF:
        if (bZero && a.kind != Kind::Const) return truncate(b.start);  // a * (1 - 0) == a
        break;
      case layout::OP_MUL:
        if (isConst(y, 1.0f) && a.kind != Kind::Const) return truncate(b.start);  // a * 1
        if (isConst(d, 1.0f) && b.kind != Kind::Const) return takeSecond(d, y, b, start);
        break;
      default:
        break;
    }
    materialise(d);
    materialise(y);
    out_.push_back(in);
    const bool nonneg = (op == layout::OP_ADD || op == layout::OP_MAX || op == layout::OP_MIN) &&
                        reg_[d].kind == Kind::Nonneg && reg_[y].kind == Kind::Nonneg;
    a = {nonneg ? Kind::Nonneg : Kind::Unknown, 0.0f, start};
  }

  // The combine's result is exactly its second operand: its code now writes d directly.
  void takeSecond(std::uint32_t d, std::uint32_t y, const Reg& b, std::size_t start) {
    rename(b.start, y, d);
    reg_[d] = {b.kind, b.c, start};
  }

  const blobtree::Program& program_;
  bool fieldOnly_;
  std::vector<Instruction>& out_;
  std::vector<std::int8_t>& zeroMemo_;  // per input position: -1 unknown, else the answer
  std::size_t pc_ = 0;
  std::uint32_t emptyBox_;
  Reg reg_[layout::MAX_FIELD_REGISTERS];
  BoundsBox pts_[layout::MAX_POINT_REGISTERS];
  std::vector<OpenSkip> skips_;
};

}  // namespace

blobtree::Program makeTapeProgram(const blobtree::Program& program) {
  blobtree::Program tape = program;
  // Null twins of every primitive: an unknown type is exactly 0 in every evaluator, with the
  // twin's colour, and no matrix.
  for (const layout::PrimitiveRecord& p : program.primitives) {
    layout::PrimitiveRecord twin = p;
    twin.meta.x = kNullPrimitive;
    twin.meta.y = 0u;
    tape.primitives.push_back(twin);
  }
  tape.boxes.push_back({{kEmptyLo, kEmptyLo, kEmptyLo, 0.0f}, {kEmptyHi, kEmptyHi, kEmptyHi, 0.0f}});
  return tape;
}

void specialiseTape(const blobtree::Program& program, const glm::dvec3& lo, const glm::dvec3& hi,
                    TapeUse use, blobtree::Program& tape) {
  std::vector<std::int8_t> memo(program.code.size(), -1);
  Pruner(program, BoundsBox{lo, hi}, use == TapeUse::Field, tape, memo).run();
}

void specialiseTapes(const blobtree::Program& program, const glm::dvec3& lo,
                     const glm::dvec3& hi, blobtree::Program& fieldTape,
                     blobtree::Program* colourTape) {
  thread_local std::vector<std::int8_t> memo;
  memo.assign(program.code.size(), -1);
  Pruner(program, BoundsBox{lo, hi}, true, fieldTape, memo).run();
  if (colourTape) Pruner(program, BoundsBox{lo, hi}, false, *colourTape, memo).run();
}

}  // namespace blobvk::cpu
