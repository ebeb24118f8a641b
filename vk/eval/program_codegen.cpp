#include "blobvk/vk/eval/program_codegen.h"

#include "blobvk/vk/eval/codegen_text.h"
#include "blobvk/vk/eval/gradient_codegen.h"
#include "blobvk/vk/eval/host_memo.h"
#include "blobvk/vk/eval/program_codegen_loops.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::vk {
namespace {

using layout::Instruction;

using codegen::lit;
using codegen::vec3Lit;
using codegen::vec4Lit;

// The qualifier on the generated function and its colour registers: glslang makes every
// operation feeding them NoContraction, so no driver fuses a * b + c (issue 15; the formulas it
// calls are precise in eval_formulas.glsl). docs/vulkan.md, "Floating point".
std::string precise(const char* type) { return std::string("precise ") + type; }

// The unrolled code's view of the instruction buffer.
constexpr const char* kCodeArray = "C";

// A run of children that are 0 in the region, each added into one register: from `pc`, groups of
// a primitive pruned into b, optionally its pow (a Ricci child: pow of 0 is 0), and the OP_ADD of
// b into a (the same a throughout, b dead after it: the register code consumes each operand
// once), stopping before `end`. Returns the instructions the run spans (0: none) and sets `a`.
// Adding +0 any number of times gives the bits of adding it once (x, or +0 for -0), so the field
// code spells the run as one `a + 0.0`: a flat blend pruned to a tile keeps only its near points.
std::uint32_t nullAddRun(const blobtree::Program& program, const PointRegion& region, std::uint32_t pc,
                         std::uint32_t end, std::uint32_t& a) {
  std::uint32_t at = pc;
  bool any = false;
  while (at < end) {
    const layout::uvec4& prim = program.code[at].code;
    if ((prim.x & 0xffu) != layout::OP_PRIM || prim.z != 0 || prim.y >= program.primitiveBoxes.size() ||
        !regionMissesBox(region, program.primitiveBoxes[prim.y]))
      break;
    const std::uint32_t b = prim.x >> 8;
    std::uint32_t next = at + 1;
    if (next < end && (program.code[next].code.x & 0xffu) == layout::OP_POW && (program.code[next].code.x >> 8) == b) ++next;
    if (next >= end) break;
    const layout::uvec4& add = program.code[next].code;
    const std::uint32_t into = add.x >> 8;
    if ((add.x & 0xffu) != layout::OP_ADD || add.y != b || into == b || (any && into != a)) break;
    a = into;
    any = true;
    at = next + 1;
  }
  return at - pc;
}

class Generator {
 public:
  Generator(const blobtree::Program& program, const CodegenOptions& options, bool colour)
      : p_(program), options_(options), colour_(colour) {}

  std::string function() {
    out_ += precise("float") + (colour_ ? " evaluateFieldColour(vec3 p, uint n, out vec3 colour) {\n"
                                         : " evaluateField(vec3 p, uint n) {\n");
    const std::uint32_t regs = std::max<std::uint32_t>(p_.fieldRegisters, 1);
    for (std::uint32_t r = 0; r < regs; ++r) {
      line(1, "float " + reg(r) + " = 0.0;");
      if (colour_) line(1, precise("vec3 ") + col(r) + " = vec3(0.0);");
    }
    for (std::uint32_t q = 1; q < p_.pointRegisters; ++q) line(1, "vec3 " + point(q) + " = p;");
    zero_.assign(regs, 1);
    emitRange(0, std::uint32_t(p_.code.size()), 1);
    if (colour_) out_ += "  colour = c0;\n";
    out_ += "  return r0;\n}\n\n";
    return std::move(out_);
  }

 private:
  // Built by append: gcc 12's -Wrestrict misfires on `"x" + std::to_string(n)`.
  static std::string named(char prefix, std::uint32_t n) {
    std::string s(1, prefix);
    s.append(std::to_string(n));
    return s;
  }
  static std::string reg(std::uint32_t r) { return named('r', r); }
  static std::string col(std::uint32_t r) { return named('c', r); }
  static std::string point(std::uint32_t q) { return q == 0 ? std::string("p") : named('q', q); }
  void line(int depth, const std::string& s) { out_ += std::string(std::size_t(depth) * 2, ' ') + s + "\n"; }

  void checkRegister(std::uint32_t r, std::uint32_t limit, const char* what) const {
    if (r >= limit) throw std::invalid_argument(std::string("specialised evaluator: ") + what + " register out of range");
  }

  std::string localPoint(std::uint32_t matrix, std::uint32_t q) const {
    if (matrix == 0) return point(q);
    if (matrix >= p_.matrices.size()) throw std::invalid_argument("specialised evaluator: matrix index out of range");
    const auto& m = p_.matrices[matrix];
    return "toLocalRows(" + vec4Lit(m.r0) + ", " + vec4Lit(m.r1) + ", " + vec4Lit(m.r2) + ", " + point(q) + ")";
  }

  std::string primitiveField(const layout::PrimitiveRecord& r, const std::string& at) const {
    const std::string p0 = vec3Lit(r.p0);
    switch (r.meta.x) {
      case layout::PRIM_POINT: return "wyvill(ddPoint(" + at + ", " + p0 + "))";
      case layout::PRIM_LINE: return "wyvill(ddLine(" + at + ", " + p0 + ", " + vec4Lit(r.p1) + "))";
      case layout::PRIM_CYLINDER:
        return "wyvill(ddCylinder(" + at + ", " + p0 + ", " + vec3Lit(r.p1) + ", " + lit(r.p2.x) + ", " + lit(r.p2.y) + "))";
      case layout::PRIM_DISC: return "wyvill(ddDisc(" + at + ", " + p0 + ", " + vec3Lit(r.p1) + ", " + lit(r.p2.x) + "))";
      case layout::PRIM_RING: return "wyvill(ddRing(" + at + ", " + p0 + ", " + vec3Lit(r.p1) + ", " + lit(r.p2.x) + "))";
      case layout::PRIM_CUBE: return "wyvill(ddCube(" + at + ", " + p0 + ", " + vec3Lit(r.p1) + "))";
      case layout::PRIM_TRIANGLE:
        return "wyvill(triangleDistance2(" + at + ", " + p0 + ", " + vec3Lit(r.p1) + ", " + vec3Lit(r.p2) + "))";
      case layout::PRIM_QUADRIC: return "quadricField(" + at + ", " + p0 + ", " + lit(r.p0.w) + ")";
      default: return "wyvill(1.0)";  // the interpreter's "no field for an unknown type"
    }
  }

  std::string warp(const layout::WarpRecord& w, const std::string& at) const {
    const std::string a = std::to_string(w.meta.y) + "u", b = std::to_string(w.meta.z) + "u";
    switch (w.meta.x) {
      case layout::WARP_TWIST: return "warpTwist(" + at + ", " + a + ", " + lit(w.params.x) + ")";
      case layout::WARP_TAPER: return "warpTaper(" + at + ", " + a + ", " + b + ", " + lit(w.params.x) + ")";
      case layout::WARP_SHEAR: return "warpShear(" + at + ", " + a + ", " + b + ", " + lit(w.params.x) + ")";
      case layout::WARP_BEND: return "warpBend(" + at + ", " + a + ", " + b + ", " + vec4Lit(w.params) + ")";
      default: return at;
    }
  }

  // Instructions [begin, end) at nesting `depth`. A skip's subtree [pc + 1, w) becomes a block
  // the subgroup enters unless all its lanes are outside the box (with branchOnSkips; else it is
  // always run); lanes outside get field and colour 0 in the skip's register afterwards. The subtree only writes its own register and the
  // ones above it (the register code is a stack discipline), which are dead once it is done, so
  // letting outside lanes run it when their neighbours need it changes nothing they keep.
  void emitRange(std::uint32_t begin, std::uint32_t end, int depth) {
    const std::uint32_t regs = std::max<std::uint32_t>(p_.fieldRegisters, 1);
    for (std::uint32_t pc = begin; pc < end; ++pc) {
      const auto& in = p_.code[pc].code;
      const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
      const std::string d = reg(dst), c = col(dst);
      switch (op) {
        case layout::OP_PRIM: {
          checkRegister(dst, regs, "field");
          std::uint32_t into = 0;
          if (const std::uint32_t run = nullAddRun(p_, options_.region, pc, end, into); run > 0) {
            checkRegister(into, regs, "field");
            std::uint32_t children = 0;
            for (std::uint32_t k = pc; k < pc + run; ++k) {
              checkRegister(p_.code[k].code.x >> 8, regs, "field");
              children += (p_.code[k].code.x & 0xffu) == layout::OP_ADD;
            }
            if (colour_) {
              // Each child's blend maps the colour c -> (c * wa + cb * 0) / w with the same wa
              // and w (a + 0 is a unless a is a zero, and then w is 0 and nothing blends; cb * 0
              // is +0 for every primitive's colour): repeated until it leaves c's bits alone, at
              // most once a child (as the generated gradient's runs, gradient_codegen.cpp).
              const std::string ra = reg(into), ca = col(into);
              line(depth, "{ float wa = max(" + ra + ", 0.0); float w = wa + 0.0; if (w > 0.0) {");
              line(depth + 1, "for (uint k = 0u; k < " + std::to_string(children) + "u; ++k) {");
              line(depth + 2, "EVAL_LOOP_TICK();");
              line(depth + 2, "precise vec3 next = (" + ca + " * wa + vec3(0.0)) / w;");
              line(depth + 2, "if (all(equal(floatBitsToUint(next), floatBitsToUint(" + ca + ")))) break;");
              line(depth + 2, ca + " = next;");
              line(depth + 1, "} } }");
            }
            line(depth, reg(into) + " = " + reg(into) + " + 0.0;  // pruned: children that are 0 in the region");
            for (std::uint32_t k = pc; k < pc + run; ++k) zero_[p_.code[k].code.x >> 8] = 0;
            pc += run - 1;
            break;
          }
          checkRegister(in.z, p_.pointRegisters, "point");
          if (in.y >= p_.primitives.size()) throw std::invalid_argument("specialised evaluator: primitive index out of range");
          const auto& prim = p_.primitives[in.y];
          zero_[dst] = in.z == 0 && in.y < p_.primitiveBoxes.size() && regionMissesBox(options_.region, p_.primitiveBoxes[in.y]);
          if (zero_[dst])
            line(depth, d + " = 0.0;  // pruned: the primitive is 0 in the region");
          else
            line(depth, d + " = " + primitiveField(prim, localPoint(prim.meta.y, in.z)) + ";");
          if (colour_) line(depth, c + " = unpackColour(" + std::to_string(prim.meta.z) + "u);");
          break;
        }
        case layout::OP_ADD:
        case layout::OP_MAX:
        case layout::OP_MIN:
        case layout::OP_DIFF:
        case layout::OP_SDIFF:
        case layout::OP_MUL: {
          checkRegister(dst, regs, "field");
          checkRegister(in.y, regs, "field");
          const std::string b = reg(in.y), cb = col(in.y);
          zero_[dst] = 0;
          if (op == layout::OP_ADD) {
            if (colour_)
              line(depth, "{ float wa = max(" + d + ", 0.0), wb = max(" + b + ", 0.0); float w = wa + wb; if (w > 0.0) " + c +
                              " = (" + c + " * wa + " + cb + " * wb) / w; }");
            line(depth, d + " = " + d + " + " + b + ";");
          } else if (op == layout::OP_MAX) {
            if (colour_) line(depth, "if (" + b + " > " + d + ") " + c + " = " + cb + ";");
            line(depth, d + " = max(" + d + ", " + b + ");");
          } else if (op == layout::OP_MIN) {
            if (colour_) line(depth, "if (" + b + " < " + d + ") " + c + " = " + cb + ";");
            line(depth, d + " = min(" + d + ", " + b + ");");
          } else if (op == layout::OP_DIFF) {
            line(depth, "{ float cut = 1.0 - " + b + ";");
            if (colour_) line(depth, "  if (cut < " + d + ") " + c + " = " + cb + ";");
            line(depth, "  " + d + " = min(" + d + ", cut); }");
          } else if (op == layout::OP_SDIFF) {
            line(depth, "{ float keep = 1.0 - " + b + ";");
            if (colour_) line(depth, "  if (keep < " + d + ") " + c + " = " + cb + ";");
            line(depth, "  " + d + " = " + d + " * keep; }");
          } else {
            if (colour_) line(depth, "if (" + b + " < " + d + ") " + c + " = " + cb + ";");
            line(depth, d + " = " + d + " * " + b + ";");
          }
          break;
        }
        case layout::OP_ONE_MINUS:
          checkRegister(dst, regs, "field");
          zero_[dst] = 0;
          line(depth, d + " = 1.0 - " + d + ";");
          break;
        case layout::OP_POW: {
          checkRegister(dst, regs, "field");
          if (zero_[dst]) {
            // powField(0, e) is +0 for every e, and pow is the dearest instruction on llvmpipe
            // (kPowCost): a Ricci blend's pruned children cost nothing.
            line(depth, "// pruned: " + d + " is 0, and so is its power");
            break;
          }
          // GLSL leaves pow(0, y) undefined; std::pow gives 0 for y > 0 (as in eval_body.glsl).
          // The exponent is read from the instruction (a uniform load), not spelled as a literal:
          // with a literal, NIR rewrites pow(x, 4.0) as x*x*x*x (pow is no arithmetic
          // instruction, so `precise` does not stop it), and the mesh would differ from the
          // interpreter's in the last bits (twisted_column's Ricci blend).
          line(depth, d + " = powField(" + d + ", uintBitsToFloat(" + std::string(kCodeArray) + "[" + std::to_string(pc) +
                          "].w));");
          break;
        }
        case layout::OP_WARP: {
          checkRegister(dst, p_.pointRegisters, "point");
          checkRegister(in.z, p_.pointRegisters, "point");
          if (dst == 0) throw std::invalid_argument("specialised evaluator: a warp writes point register 0");
          if (in.y >= p_.warps.size()) throw std::invalid_argument("specialised evaluator: warp index out of range");
          const auto& w = p_.warps[in.y];
          line(depth, point(dst) + " = " + warp(w, localPoint(w.meta.w, in.z)) + ";");
          break;
        }
        case layout::OP_SKIP: {
          checkRegister(dst, regs, "field");
          checkRegister(in.z, p_.pointRegisters, "point");
          if (in.y >= p_.boxes.size()) throw std::invalid_argument("specialised evaluator: box index out of range");
          const std::uint32_t target = in.w;
          if (target <= pc || target > end) throw std::invalid_argument("specialised evaluator: skip target out of its range");
          const auto& box = p_.boxes[in.y];
          if (in.z == 0 && regionMissesBox(options_.region, box)) {
            line(depth, d + " = 0.0;" + (colour_ ? " " + c + " = vec3(0.0);" : std::string()) + "  // pruned: outside the region");
            zero_[dst] = 1;
            pc = target - 1;
            break;
          }
          std::string o = "out";
          o.append(std::to_string(pc));
          line(depth, "{");
          line(depth + 1, "bool " + o + " = outsideBoxBounds(" + vec3Lit(box.lo) + ", " + vec3Lit(box.hi) + ", " +
                              point(in.z) + ");");
          if (options_.branchOnSkips && target - pc - 1 >= options_.minBranchInstructions) {
            // A loop rather than an `if`: the subgroup leaves it as soon as no lane is active.
            line(depth + 1, "while (!subgroupAll(" + o + ")) {");
            line(depth + 2, "EVAL_LOOP_TICK();");
            emitRange(pc + 1, target, depth + 2);
            line(depth + 2, "break;");
            line(depth + 1, "}");
          } else {
            emitRange(pc + 1, target, depth + 1);
          }
          line(depth + 1, "if (" + o + ") { " + d + " = 0.0;" + (colour_ ? " " + c + " = vec3(0.0);" : std::string()) + " }");
          line(depth, "}");
          std::fill(zero_.begin(), zero_.end(), 0);  // the block may or may not have run
          pc = target - 1;
          break;
        }
        default:
          throw std::invalid_argument("specialised evaluator: unknown opcode " + std::to_string(op));
      }
    }
  }

  const blobtree::Program& p_;
  CodegenOptions options_;
  bool colour_;
  std::vector<char> zero_;  // per field register: known to hold +0 here (a pruned primitive or subtree)
  std::string out_;
};

}  // namespace

bool regionMissesBox(const PointRegion& region, const layout::BoxRecord& box) {
  if (!region.valid) return false;
  const float lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
  for (int a = 0; a < 3; ++a)
    if (region.hi[a] < lo[a] || region.lo[a] > hi[a]) return true;
  return false;
}

std::uint32_t prunedEvaluationCost(const blobtree::Program& program, const PointRegion& region) {
  // The walk the generator makes (Generator::emitRange): a skip's subtree a range of its own,
  // registers known to hold 0 (a pruned primitive or subtree), whose power the code leaves out,
  // forgotten after a subtree (it may or may not have run).
  std::uint32_t count = 0;
  std::vector<char> zero(std::max<std::uint32_t>(program.fieldRegisters, 1), 1);
  auto known = [&](std::uint32_t r) -> char* { return r < zero.size() ? &zero[r] : nullptr; };
  const std::uint32_t n = std::uint32_t(program.code.size());
  auto walk = [&](auto&& self, std::uint32_t begin, std::uint32_t end) -> void {
    for (std::uint32_t pc = begin; pc < end; ++pc) {
      const auto& in = program.code[pc].code;
      const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
      if (op == layout::OP_SKIP && in.w > pc && in.w <= end) {
        if (in.z == 0 && in.y < program.boxes.size() && regionMissesBox(region, program.boxes[in.y])) {
          if (char* z = known(dst)) *z = 1;
        } else {
          count += 1;  // the box test
          self(self, pc + 1, in.w);
          std::fill(zero.begin(), zero.end(), 0);
        }
        pc = in.w - 1;
        continue;
      }
      if (op == layout::OP_PRIM) {
        std::uint32_t into = 0;
        if (const std::uint32_t run = nullAddRun(program, region, pc, end, into); run > 0) {
          for (std::uint32_t k = pc; k < pc + run; ++k)
            if (char* z = known(program.code[k].code.x >> 8)) *z = 0;
          count += 1;  // the one addition of 0
          pc += run - 1;
          continue;
        }
        if (in.z == 0 && in.y < program.primitiveBoxes.size() && regionMissesBox(region, program.primitiveBoxes[in.y])) {
          if (char* z = known(dst)) *z = 1;
          continue;
        }
      }
      if (op == layout::OP_POW && known(dst) && *known(dst)) continue;
      if (op != layout::OP_WARP)
        if (char* z = known(dst)) *z = 0;
      count += op == layout::OP_PRIM || op == layout::OP_WARP ? kPrimitiveCost : op == layout::OP_POW ? kPowCost : 1;
    }
  };
  walk(walk, 0, n);
  return count;
}

std::uint64_t programFingerprint(const blobtree::Program& program) {
  MemoKey f;  // the records are plain data without padding holes (the layout header asserts their sizes)
  f.array(program.code);
  f.array(program.primitives);
  f.array(program.matrices);
  f.array(program.boxes);
  f.array(program.warps);
  f.array(program.primitiveBoxes);
  f.add(program.fieldRegisters);
  f.add(program.pointRegisters);
  return f.h;
}

MemoKey& addLoopOptions(MemoKey& key, const LoopOptions& loops) {
  return key.add(loops.enabled).add(loops.minCount).add(loops.minInstructions).add(loops.minProgramInstructions);
}

std::uint64_t evaluatorFingerprint(std::uint64_t programFingerprint, const CodegenOptions& options) {
  MemoKey f;
  f.add(programFingerprint);
  f.add(options.branchOnSkips);
  f.add(options.minBranchInstructions);
  f.add(options.region.valid);
  addLoopOptions(f, options.loops);
  f.add(options.gradient);
  if (options.region.valid) {
    f.add(options.region.lo);
    f.add(options.region.hi);
  }
  return f.h;
}

std::uint64_t evaluatorFingerprint(const blobtree::Program& program, const CodegenOptions& options) {
  return evaluatorFingerprint(programFingerprint(program), options);
}

std::uint32_t branchedInstructionCount(const blobtree::Program& program, const PointRegion& region) {
  std::uint32_t count = 0;
  for (std::size_t pc = 0; pc < program.code.size(); ++pc, ++count) {
    const auto& in = program.code[pc].code;
    if ((in.x & 0xffu) == layout::OP_SKIP && in.z == 0 && in.y < program.boxes.size() && in.w > pc &&
        regionMissesBox(region, program.boxes[in.y]))
      pc = std::size_t(in.w) - 1;
  }
  return count;
}

std::uint32_t prunedInstructionCount(const blobtree::Program& program, const PointRegion& region) {
  std::uint32_t count = 0;
  const std::uint32_t n = std::uint32_t(program.code.size());
  std::vector<std::uint32_t> open;  // the targets of the skips whose subtrees the walk is in
  for (std::uint32_t pc = 0; pc < n; ++count) {
    while (!open.empty() && open.back() <= pc) open.pop_back();
    const auto& in = program.code[pc].code;
    if ((in.x & 0xffu) == layout::OP_SKIP && in.z == 0 && in.y < program.boxes.size() && in.w > pc && in.w <= n) {
      if (regionMissesBox(region, program.boxes[in.y])) {
        pc = in.w;
        continue;
      }
      open.push_back(in.w);
    }
    std::uint32_t into = 0;
    const std::uint32_t run = nullAddRun(program, region, pc, open.empty() ? n : open.back(), into);
    pc += std::max(run, 1u);
  }
  return count;
}

namespace {
bool registersFit(const blobtree::Program& program) {
  return !program.code.empty() && program.fieldRegisters <= layout::MAX_FIELD_REGISTERS && program.pointRegisters >= 1 &&
         program.pointRegisters <= layout::MAX_POINT_REGISTERS;
}

struct Generated {
  std::string glsl;
  std::uint32_t emitted = 0;
};

// Declares the instructions (binding 0, as eval_program.glsl's ProgramCode) for the exponents of
// OP_POW; unrolled code only (the looped form declares the binding itself).
std::string codeDeclaration(const blobtree::Program& program) {
  for (const auto& in : program.code)
    if ((in.code.x & 0xffu) == layout::OP_POW)
      return std::string("layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 0) readonly buffer SpecialisedCode {\n  uvec4 ") +
             kCodeArray + "[];\n};\n\n";
  return {};
}

// Whether the program pruned to `region` is long enough for loops (LoopOptions::minProgramInstructions).
bool wantsLoops(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops) {
  return loops.enabled &&
         (loops.minProgramInstructions == 0 || prunedInstructionCount(program, region) > loops.minProgramInstructions);
}

MemoKey loopsKey(const blobtree::Program& program, const LoopOptions& loops) {
  MemoKey k;
  return addLoopOptions(k.add(programFingerprint(program)), loops);
}

// CodeShapes::analyse, remembered per program and loop options: the loop limit, the evaluator
// choice, the tiles and the upload each ask for it, on every job (GPUs loop any repeated shape:
// tens of analyses of the tower a job, 0.8 ms of its host time).
std::shared_ptr<const CodeShapes> analysedShapes(const blobtree::Program& program, const LoopOptions& loops) {
  static HostMemo<std::shared_ptr<const CodeShapes>> memo;
  return memo.get(loopsKey(program, loops),
                  [&] { return std::shared_ptr<const CodeShapes>(CodeShapes::analyse(program, loops)); });
}

// The looped form when the code parses into shapes (and loops are on for it), else unrolled.
Generated generate(const blobtree::Program& program, const CodegenOptions& options) {
  Generated g;
  std::shared_ptr<const CodeShapes> shapes;
  if (wantsLoops(program, options.region, options.loops)) shapes = analysedShapes(program, options.loops);
  if (shapes) {
    // Looped code branches on skips (CodegenOptions::loops).
    CodegenOptions looped = options;
    looped.branchOnSkips = true;
    g.glsl = generateLoopedEvaluators(program, *shapes, looped, &g.emitted);
  } else {
    g.emitted = prunedInstructionCount(program, options.region);
    // The field, the colour and the gradient for the vertex kernels' normals, unrolled. glslang
    // (optimiser off) keeps uncalled functions in the SPIR-V and lavapipe translates every one, so
    // a kernel that needs only some says so (shaders/eval_program.glsl: EVALUATOR_FIELD_ONLY,
    // EVALUATOR_GRADIENT_ONLY) and the others are not compiled: a field tile's kernel held the
    // whole colour evaluator and the gradient beside its field, the vertex kernel both evaluators.
    g.glsl = codeDeclaration(program) + "#ifndef EVALUATOR_GRADIENT_ONLY\n" + Generator(program, options, false).function() +
             "#ifndef EVALUATOR_FIELD_ONLY\n" + Generator(program, options, true).function() + "#endif\n#endif\n" +
             (options.gradient ? "#ifndef EVALUATOR_FIELD_ONLY\n" + generateSpecialisedGradient(program, options, kCodeArray) +
                                     "#endif\n"
                               : std::string());
  }
  return g;
}
}  // namespace

bool specialisedCodeLoops(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops) {
  return wantsLoops(program, region, loops) && analysedShapes(program, loops) != nullptr;
}

std::uint32_t specialisedCodeSize(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops) {
  if (!wantsLoops(program, region, loops)) return prunedInstructionCount(program, region);
  // Generating the code to count it: remembered, as the evaluator choice and the tiles ask again
  // every job.
  static HostMemo<std::uint32_t> memo;
  MemoKey key = loopsKey(program, loops);
  key.add(region.valid);
  if (region.valid) key.add(region.lo).add(region.hi);
  return memo.get(key, [&] {
    CodegenOptions o;
    o.region = region;
    o.loops = loops;
    return generate(program, o).emitted;
  });
}

bool canSpecialise(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops) {
  if (!registersFit(program)) return false;
  if (program.code.size() <= kMaxSpecialisedInstructions) return true;
  return specialisedCodeSize(program, region, loops) <= kMaxSpecialisedInstructions;
}

std::vector<layout::uvec4> specialisedData(const blobtree::Program& program, const LoopOptions& loops) {
  // The whole program's code is the longest of its regions': when it is unrolled, so is every tile's.
  if (!wantsLoops(program, {}, loops)) return {};
  const auto shapes = analysedShapes(program, loops);
  return shapes ? shapes->data() : std::vector<layout::uvec4>{};
}

std::string generateSpecialisedEvaluator(const blobtree::Program& program, const CodegenOptions& options,
                                         std::uint32_t* emitted) {
  if (!registersFit(program))
    throw std::invalid_argument("specialised evaluator: the program is empty or uses too many registers");
  Generated g = generate(program, options);
  if (g.emitted > kMaxSpecialisedInstructions)
    throw std::invalid_argument("specialised evaluator: the program spells out " + std::to_string(g.emitted) +
                                " instructions in its region (1.." + std::to_string(kMaxSpecialisedInstructions) +
                                " can be specialised)");
  if (emitted) *emitted = g.emitted;
  std::string s =
      "// Generated by vk/eval/program_codegen.cpp: the specialised evaluator of one Program, in place of\n"
      "// shaders/eval_program.glsl (same interface).\n"
      "#ifndef BLOBVK_EVAL_PROGRAM_GLSL\n#define BLOBVK_EVAL_PROGRAM_GLSL\n"
      "#extension GL_KHR_shader_subgroup_vote : require\n"
      "#include \"program_layout.h\"\n#include \"eval_loop_count.glsl\"\n#include \"eval_formulas.glsl\"\n\n";
  // What the whole program contains, for the vertex pass's gradient interpreter
  // (shaders/eval_gradient.glsl), which runs the uploaded code and folds away what is absent:
  // the looped form brings no gradient of its own.
  std::uint32_t ops = 0, prims = 0, warps = 0;
  for (const auto& in : program.code) ops |= 1u << (in.code.x & 0x1fu);
  for (const auto& prim : program.primitives) prims |= (1u << (prim.meta.x & 0x1fu)) | (prim.meta.y ? 0x80000000u : 0u);
  for (const auto& warp : program.warps) warps |= (1u << (warp.meta.x & 0x1fu)) | (warp.meta.w ? 0x80000000u : 0u);
  char masks[256];
  std::snprintf(masks, sizeof masks,
                "#define GRADIENT_OP_MASK 0x%08xu\n#define GRADIENT_PRIM_MASK 0x%08xu\n#define GRADIENT_WARP_MASK 0x%08xu\n"
                "#define GRADIENT_FIELD_REGS %uu\n\n",
                ops, prims, warps, std::max<std::uint32_t>(program.fieldRegisters, 1));
  s += masks;
  s += g.glsl;
  s += "#endif\n";
  return s;
}

}  // namespace blobvk::vk
