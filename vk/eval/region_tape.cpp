#include "blobvk/vk/eval/region_tape.h"

#include <cfloat>

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
  // Instructions [i, next) leave 0 in register d: one "write 0" (a skip on the empty box), or
  // nothing at all when only the field is wanted and the next instruction adds d to another
  // register (d is dead after it: the register code consumes each operand once).
  auto zero = [&](std::uint32_t d, std::size_t next) -> std::size_t {
    if (use == TapeUse::Field && next < n) {
      const layout::uvec4& add = tape[next].code;
      if ((add.x & 0xffu) == layout::OP_ADD && add.y == d && (add.x >> 8) != d) {
        at[next] = here();
        return next + 1;
      }
    }
    out.push_back({{layout::OP_SKIP | (d << 8), emptyBox, 0u, here() + 1u}});
    return next;
  };
  for (std::size_t i = 0; i < n;) {
    at[i] = here();
    const layout::uvec4& in = tape[i].code;
    const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
    if (op == layout::OP_SKIP) {
      if (in.y == emptyBox) {  // a parent tape's "write 0"
        i = zero(dst, i + 1);
        continue;
      }
      if (in.z == 0 && in.y < program.boxes.size() && in.w > i && in.w <= n) {
        const layout::BoxRecord& box = program.boxes[in.y];
        if (regionMissesBox(region, box)) {  // every point of the region skips the subtree
          i = zero(dst, in.w);
          continue;
        }
        if (regionInsideBox(region, box)) {  // no point skips it: the test goes, the subtree stays
          ++i;
          continue;
        }
      }
    } else if (op == layout::OP_PRIM && use == TapeUse::Field && in.z == 0 && in.y < program.primitiveBoxes.size() &&
               regionMissesBox(region, program.primitiveBoxes[in.y])) {
      i = zero(dst, i + 1);
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
