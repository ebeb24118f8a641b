#include "blobvk/vk/eval/region_tape.h"

#include <cfloat>
#include <cmath>
#include <cstdint>

namespace blobvk::vk {

layout::BoxRecord emptySkipBox() {
  layout::BoxRecord box{};
  box.lo = {FLT_MAX, FLT_MAX, FLT_MAX, 0.0f};
  box.hi = {-FLT_MAX, -FLT_MAX, -FLT_MAX, 0.0f};
  return box;
}

bool regionInsideBox(const PointRegion& region, const layout::BoxRecord& box) {
  if (!region.valid) return false;
  const float lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
  for (int a = 0; a < 3; ++a)
    if (region.lo[a] < lo[a] || region.hi[a] > hi[a]) return false;
  return true;
}

bool regionPrunesPrimitive(const blobtree::Program& program, const PointRegion& region, const layout::uvec4& in) {
  return (in.x & 0xffu) == layout::OP_PRIM && in.z == 0 && in.y < program.primitives.size() &&
         in.y < program.primitiveBoxes.size() && regionMissesBox(region, program.primitiveBoxes[in.y]);
}

std::uint32_t prunedGradientNegativeZeros(const blobtree::Program& program, std::uint32_t primitive) {
  const std::uint32_t matrix = program.primitives[primitive].meta.y;
  if (!matrix || matrix >= program.matrices.size()) return 0u;
  const auto& m = program.matrices[matrix];
  const float rows[3][3] = {{m.r0.x, m.r0.y, m.r0.z}, {m.r1.x, m.r1.y, m.r1.z}, {m.r2.x, m.r2.y, m.r2.z}};
  std::uint32_t bits = 0;
  for (int j = 0; j < 3; ++j)
    if (std::signbit(rows[0][j]) && std::signbit(rows[1][j]) && std::signbit(rows[2][j])) bits |= 1u << j;
  return bits;
}

namespace {
bool sameCode(const layout::uvec4& a, const layout::uvec4& b) {
  return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w;
}
}  // namespace

std::uint32_t appendRegionTape(std::span<const layout::Instruction> tape, const blobtree::Program& program,
                               const PointRegion& region, std::uint32_t emptyBox, TapeUse use,
                               std::vector<layout::Instruction>& out) {
  const std::size_t start = out.size(), n = tape.size();
  if (!region.valid) {
    out.insert(out.end(), tape.begin(), tape.end());
    return std::uint32_t(n);
  }
  // at[i]: where the first instruction kept at or after old instruction i lands (relative), set
  // for every instruction a kept skip can jump to: the walk visits each one (subtrees nest), or
  // a dropped addition below sets it. Entries inside removed subtrees stay unset and unread.
  thread_local std::vector<std::uint32_t> at;
  thread_local std::vector<std::size_t> jumps;  // kept skips, their target still the old index
  at.resize(n + 1);
  jumps.clear();
  auto here = [&] { return std::uint32_t(out.size() - start); };
  // The last "write 0" kept: the old index of what it stands for and where it landed (below).
  std::size_t zeroFrom = n, zeroAt = SIZE_MAX;
  // Instructions [from, next) leave 0 in register d: one "write 0" (a skip on the empty box), or
  // nothing at all when only the field is wanted and the next instruction adds d to another
  // register (d is dead after it: the register code consumes each operand once).
  auto zero = [&](std::uint32_t d, std::size_t from, std::size_t next) -> std::size_t {
    if (use == TapeUse::Field && next < n) {
      // A Ricci blend's child is raised to its power first: pow(0, n) is +0 (powField).
      const std::size_t power = (tape[next].code.x & 0xffu) == layout::OP_POW && (tape[next].code.x >> 8) == d;
      const std::size_t addition = next + power;
      if (addition < n && (tape[addition].code.x & 0xffu) == layout::OP_ADD && tape[addition].code.y == d &&
          (tape[addition].code.x >> 8) != d) {
        at[next] = at[addition] = here();
        return addition + 1;
      }
    }
    zeroFrom = from;
    zeroAt = out.size();
    out.push_back({{layout::OP_SKIP | (d << 8), emptyBox, 0u, here() + 1u}});
    return next;
  };
  // Which instructions a skip jumps to: a run of null additions (vertex tapes) must not swallow
  // one, and a repeated zero operand (below) is only dropped where no jump lands on it.
  thread_local std::vector<char> target;
  target.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if ((tape[i].code.x & 0xffu) == layout::OP_SKIP && tape[i].code.w <= n) target[tape[i].code.w] = 1;
  // A union, intersection or difference of many children of which the region meets few leaves a
  // run of the same constant operand and its combination: ["write 0" into d, OP_MAX a d], or
  // ["write 0" into d, OP_ONE_MINUS d, OP_MIN a d] for a reordered difference's cutter. Max or
  // min with a constant already taken changes nothing (field, colour and gradient: an operand is
  // taken only when strictly greater, or smaller), so each repeat goes: a brick of a union of 200
  // instances runs its own few.
  auto writesZero = [&](std::size_t k, std::uint32_t d) {
    const layout::uvec4& c = out[k].code;
    return (c.x & 0xffu) == layout::OP_SKIP && (c.x >> 8) == d && c.y == emptyBox && c.w == k - start + 1;
  };
  auto unaryOn = [&](const layout::uvec4& c, std::uint32_t d) {
    const std::uint32_t op = c.x & 0xffu;
    return (op == layout::OP_ONE_MINUS || op == layout::OP_POW) && (c.x >> 8) == d;
  };
  // The length of the constant operand that tape[i] combines, when it repeats the operand and
  // combination just before it; else 0.
  auto repeatedConstantOperand = [&](std::size_t i) -> std::size_t {
    const layout::uvec4& in = tape[i].code;
    const std::uint32_t op = in.x & 0xffu, a = in.x >> 8, d = in.y;
    if ((op != layout::OP_MAX && op != layout::OP_MIN && op != layout::OP_DIFF) || a == d) return 0;
    const std::size_t k = out.size();
    if (zeroAt == SIZE_MAX || zeroAt >= k || target[zeroFrom] || !writesZero(zeroAt, d)) return 0;
    const std::size_t length = k - zeroAt;  // the "write 0" and the unary operations after it
    if (zeroAt < start + length + 1) return 0;
    const std::size_t before = zeroAt - 1 - length;
    if (!sameCode(out[zeroAt - 1].code, in) || !writesZero(before, d)) return 0;
    for (std::size_t j = 1; j < length; ++j)
      if (!unaryOn(out[zeroAt + j].code, d) || !sameCode(out[before + j].code, out[zeroAt + j].code)) return 0;
    return length;
  };
  auto prunedPrimitive = [&](const layout::uvec4& in) { return regionPrunesPrimitive(program, region, in); };
  for (std::size_t i = 0; i < n;) {
    at[i] = here();
    const layout::uvec4& in = tape[i].code;
    const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
    if (use == TapeUse::Vertex && prunedPrimitive(in)) {
      // Pairs (pruned primitive into b, OP_ADD of b into a) with the same a and b, none a jump target.
      std::uint32_t run = 0, a = 0, negative = 7, last = 0;
      for (std::size_t k = i; k + 1 < n; k += 2) {
        const layout::uvec4& prim = tape[k].code;
        const layout::uvec4& add = tape[k + 1].code;
        if (!prunedPrimitive(prim) || (prim.x >> 8) != dst || (k > i && target[k]) || target[k + 1]) break;
        if ((add.x & 0xffu) != layout::OP_ADD || add.y != dst || (add.x >> 8) == dst) break;
        if (run > 0 && (add.x >> 8) != a) break;
        a = add.x >> 8;
        negative &= prunedGradientNegativeZeros(program, prim.y);
        last = prim.y;
        ++run;
      }
      if (run > 0) {
        out.push_back({{layout::OP_NULL_ADDS | (a << 8), last, negative, run}});
        i += 2 * std::size_t(run);
        continue;
      }
    }
    if (op == layout::OP_SKIP) {
      if (in.y == emptyBox) {  // a parent tape's "write 0"
        i = zero(dst, i, i + 1);
        continue;
      }
      if (in.z == 0 && in.y < program.boxes.size() && in.w > i && in.w <= n) {
        const layout::BoxRecord& box = program.boxes[in.y];
        if (regionMissesBox(region, box)) {  // every point of the region skips the subtree
          i = zero(dst, i, in.w);
          continue;
        }
        if (regionInsideBox(region, box)) {  // no point skips it: the test goes, the subtree stays
          ++i;
          continue;
        }
      }
    } else if (use == TapeUse::Field && prunedPrimitive(in)) {
      i = zero(dst, i, i + 1);
      continue;
    } else if (const std::size_t length = repeatedConstantOperand(i)) {
      out.resize(out.size() - length);  // the operand goes, and its combination is not kept
      for (std::size_t j = zeroFrom; j <= i; ++j) at[j] = here();
      zeroAt = SIZE_MAX;
      ++i;
      continue;
    }
    if (op == layout::OP_SKIP) jumps.push_back(out.size());
    out.push_back(tape[i]);
    ++i;
  }
  at[n] = here();
  for (std::size_t j : jumps) out[j].code.w = at[out[j].code.w];
  return here();
}

}  // namespace blobvk::vk
