#include "blobvk/vk/eval/gradient_codegen.h"

#include "blobvk/vk/eval/codegen_text.h"
#include "blobvk/vk/eval/region_tape.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

namespace blobvk::vk {
namespace {

using codegen::vec3Lit;

// Runs of pruned primitives added into one register shorter than this stay pair by pair.
constexpr std::uint32_t kMinNullAddRun = 3;

// Each instruction becomes the statements shaders/eval_gradient.glsl's loop runs for it, in the
// same order, on named registers: field rN, gradient gN, colour cN, point qN with its Jacobian's
// rows jaN, jbN, jcN (point register 0 is p, whose Jacobian is the identity).
class GradientGenerator {
 public:
  GradientGenerator(const blobtree::Program& program, const CodegenOptions& options, const char* codeArray)
      : p_(program), options_(options), codeArray_(codeArray) {
    for (const auto& in : p_.code) warps_ |= (in.code.x & 0xffu) == layout::OP_WARP;
  }

  // Whether the program meets what the generated code assumes beyond generateSpecialisedEvaluator's
  // checks: Program::matrices[0] is the identity (Z is one of its zeros).
  bool supported() const {
    if (p_.matrices.empty()) return false;
    const auto& m = p_.matrices[0];
    const layout::vec4 rows[3] = {m.r0, m.r1, m.r2};
    for (int i = 0; i < 3; ++i) {
      const float v[3] = {rows[i].x, rows[i].y, rows[i].z};
      for (int j = 0; j < 3; ++j)
        if (v[j] != (i == j ? 1.0f : 0.0f) || std::signbit(v[j])) return false;
    }
    return true;
  }

  std::string function() {
    out_ += "#define BLOBVK_GENERATED_GRADIENT 1\n#include \"eval_gradient_formulas.glsl\"\n\n";
    // One gradient function per primitive type, its type a constant: the driver's compiler then
    // sees one formula at each primitive, not every type's (eval_gradient_primitive_body.glsl).
    std::set<std::uint32_t> types;
    for (const auto& prim : p_.primitives) types.insert(prim.meta.x);
    for (std::uint32_t t : types)
      out_ += "precise float " + primitiveGradientName(t) +
              "(vec3 p, vec4 p0, vec4 p1, vec4 p2, out vec3 grad) {\n  const uint type = " + std::to_string(t) +
              "u;\n#include \"eval_gradient_primitive_body.glsl\"\n}\n\n";
    // Record values are literals, except zeros: NIR folds x * 0.0 into 0.0 and y + 0.0 into y
    // (the shader does not ask to preserve signed zeros), and where the other terms are -0 the
    // sum then turns from +0 into -0, a sign the normal keeps. The interpreter's zeros come from
    // its buffers; here they are Z, loaded once (an entry of Program::matrices[0], the identity),
    // which nothing can fold. The same goes for the identity Jacobian's and the warps' zeros.
    out_ += "layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 2) readonly buffer GradientMatrices { "
            "MatrixRecord gradientMatrices[]; };\n\n";
    // `precise` on the function (its field), the gradient, colour, point and Jacobian registers:
    // glslang then makes every operation feeding them NoContraction, as in the interpreter.
    out_ += "precise float evaluateGradient(vec3 p, uint n, bool wantColour, out vec3 gradient, out vec3 colour) {\n";
    line(1, "float Z = gradientMatrices[0].r0.y;");
    const std::uint32_t regs = std::max<std::uint32_t>(p_.fieldRegisters, 1);
    for (std::uint32_t r = 0; r < regs; ++r)
      line(1, "float " + named('r', r) + " = 0.0; precise vec3 " + named('g', r) + " = vec3(0.0); precise vec3 " +
                  named('c', r) + " = vec3(0.0);");
    if (warps_) {
      // As the interpreter: every point register starts as p with the identity Jacobian.
      for (std::uint32_t q = 1; q < p_.pointRegisters; ++q)
        line(1, "precise vec3 " + point(q) + " = p, " + named3("ja", q) + " = vec3(1.0, Z, Z), " + named3("jb", q) + " = vec3(Z, 1.0, Z), " +
                    named3("jc", q) + " = vec3(Z, Z, 1.0);");
    }
    emitRange(0, std::uint32_t(p_.code.size()), 1);
    line(1, "gradient = g0;");
    line(1, "colour = c0;");
    line(1, "return r0;");
    out_ += "}\n\n";
    return std::move(out_);
  }

 private:
  static std::string named(char prefix, std::uint32_t n) {
    std::string s(1, prefix);
    s.append(std::to_string(n));
    return s;
  }
  static std::string named3(const char* prefix, std::uint32_t n) {
    std::string s(prefix);
    s.append(std::to_string(n));
    return s;
  }
  // The interpreter reads point registers only when the program warps (else every point is p).
  std::string point(std::uint32_t q) const { return q == 0 || !warps_ ? std::string("p") : named('q', q); }
  void line(int depth, const std::string& s) { out_ += std::string(std::size_t(depth) * 2, ' ') + s + "\n"; }

  void check(bool ok, const char* what) const {
    if (!ok) throw std::invalid_argument(std::string("specialised gradient: ") + what);
  }

  // A record value in arithmetic: a literal, or Z (-Z) for +0 (-0).
  static std::string num(float v) {
    if (v == 0.0f) return std::signbit(v) ? "-Z" : "Z";
    return codegen::lit(v);
  }
  static std::string v3(const layout::vec4& v) { return "vec3(" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + ")"; }
  static std::string primitiveGradientName(std::uint32_t type) { return "primitiveGradientOfType" + std::to_string(type); }

  static std::string v4(const layout::vec4& v) {
    return "vec4(" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + ", " + num(v.w) + ")";
  }

  // The matrix's three rows as arguments.
  std::string rows(std::uint32_t matrix) const {
    check(matrix < p_.matrices.size(), "matrix index out of range");
    const auto& m = p_.matrices[matrix];
    return v4(m.r0) + ", " + v4(m.r1) + ", " + v4(m.r2);
  }

  void primitive(const layout::uvec4& in, int depth) {
    const std::uint32_t dst = in.x >> 8, z = warps_ ? in.z : 0;
    check(in.y < p_.primitives.size(), "primitive index out of range");
    const auto& prim = p_.primitives[in.y];
    const std::uint32_t matrix = prim.meta.y;
    const std::string at = matrix ? "toLocalRows(" + rows(matrix) + ", " + point(z) + ")" : point(z);
    const std::string d = named('r', dst), g = named('g', dst);
    // Pruned to the region as the field code prunes it (program_codegen.cpp): outside its support
    // box a primitive's formula gives field +0 and gradient +0, then M^T (+0) with a matrix, whose
    // signs of zero (-0 where a column's entries are all negative) a normal that is 0 along an axis
    // keeps. The zeros are Z, loaded: NIR folds y + 0.0 into y, which turns -0 + +0 (+0 at run
    // time, as in the whole program's kernel) into -0.
    if (in.z == 0 && in.y < p_.primitiveBoxes.size() && regionMissesBox(options_.region, p_.primitiveBoxes[in.y])) {
      line(depth, "{ " + d + " = Z;  // pruned: the primitive is 0 in the region");
      line(depth + 1, g + " = " + (matrix ? "transposeTimesRows(" + rows(matrix) + ", vec3(Z))" : std::string("vec3(Z)")) + ";");
      line(depth + 1, "if (wantColour) " + named('c', dst) + " = unpackColour(" + std::to_string(prim.meta.z) + "u); }");
      return;
    }
    line(depth, "{ precise vec3 gl;");
    line(depth + 1, d + " = " + primitiveGradientName(prim.meta.x) + "(" + at + ", " + v4(prim.p0) + ", " +
                        v4(prim.p1) + ", " + v4(prim.p2) + ", gl);");
    if (matrix) line(depth + 1, "gl = transposeTimesRows(" + rows(matrix) + ", gl);");
    // Register 0 is p itself: its gradient is not multiplied by the identity (that would turn -0 into +0).
    if (z == 0)
      line(depth + 1, g + " = gl;");
    else
      line(depth + 1, g + " = jacobianTransposeTimes(" + named3("ja", z) + ", " + named3("jb", z) + ", " + named3("jc", z) +
                          ", gl);");
    line(depth + 1, "if (wantColour) " + named('c', dst) + " = unpackColour(" + std::to_string(prim.meta.z) + "u); }");
  }

  // A primitive the region prunes: +0 field and gradient M^T (+0) everywhere in it.
  bool pruned(const layout::uvec4& in) const { return regionPrunesPrimitive(p_, options_.region, in); }

  // Pairs (pruned primitive into register b, OP_ADD of b into a) from `pc` on, with the same a
  // and b: a blend's children outside the region (random128: most of its 128 points in a tile).
  std::uint32_t nullAddRun(std::uint32_t pc, std::uint32_t end) const {
    const auto& first = p_.code[pc].code;
    const std::uint32_t b = first.x >> 8;
    std::uint32_t a = 0, run = 0;
    for (std::uint32_t at = pc; at + 1 < end; at += 2) {
      const auto& prim = p_.code[at].code;
      const auto& add = p_.code[at + 1].code;
      if ((prim.x & 0xffu) != layout::OP_PRIM || (prim.x >> 8) != b || !pruned(prim)) break;
      if ((add.x & 0xffu) != layout::OP_ADD || add.y != b || (add.x >> 8) == b) break;
      if (run == 0) a = add.x >> 8;
      if ((add.x >> 8) != a) break;
      ++run;
    }
    return run;
  }

  // `run` pairs of nullAddRun as a few statements with the same bits as the pairs one by one.
  //  - Field: a + (+0) run times is a + (+0) once (it only turns -0 into +0).
  //  - Gradient: adding -0 changes nothing and adding +0 twice is adding it once, so each
  //    component adds +0 once where any pair's zero is +0, else -0.
  //  - Colour: each pair's blend is the same map of a's colour, c -> (c * wa + cb * 0) / w (wa, w
  //    the same at every pair: a + 0 is a unless a is a zero, and then w is 0 and nothing blends;
  //    cb * 0 is +0 for every primitive's colour, unpackColour's being finite and >= 0). Once the
  //    map leaves the colour's bits unchanged it always will, so a loop stops there: usually after
  //    one or two steps (as the CPU's colour tapes stop their chains of null twins). On llvmpipe a
  //    loop is the one branch that skips work; unrolled, every pair paid three divisions.
  //  - Register b ends as the last pair left it.
  void nullAdds(std::uint32_t pc, std::uint32_t run, int depth) {
    const auto& last = p_.code[pc + 2 * (run - 1)].code;
    const std::uint32_t b = last.x >> 8, a = p_.code[pc + 1].code.x >> 8;
    std::uint32_t negative = 7;  // bit j: component j of every pair's zero is -0
    for (std::uint32_t k = 0; k < run; ++k) negative &= prunedGradientNegativeZeros(p_, p_.code[pc + 2 * k].code.y);
    const std::string ra = named('r', a), rb = named('r', b), ga = named('g', a), ca = named('c', a), cb = named('c', b);
    line(depth, "// " + std::to_string(run) + " pruned primitives added into " + ra + " (the bits of adding each)");
    primitive(last, depth);
    line(depth, "if (wantColour) { float wa = max(" + ra + ", 0.0), wb = max(" + rb + ", 0.0); float w = wa + wb; if (w > 0.0) {");
    line(depth + 1, "for (uint k = 0u; k < " + std::to_string(run) + "u; ++k) {");
    line(depth + 2, "EVAL_LOOP_TICK();");
    line(depth + 2, "precise vec3 next = (" + ca + " * wa + " + cb + " * wb) / w;");
    line(depth + 2, "if (all(equal(floatBitsToUint(next), floatBitsToUint(" + ca + ")))) break;");
    line(depth + 2, ca + " = next;");
    line(depth + 1, "} } }");
    auto zero = [](bool negative) { return std::string(negative ? "-Z" : "Z"); };
    line(depth, ra + " = " + ra + " + " + rb + "; " + ga + " = " + ga + " + vec3(" + zero(negative & 1u) + ", " +
                    zero(negative & 2u) + ", " + zero(negative & 4u) + ");");
  }

  void combine(std::uint32_t op, std::uint32_t dst, std::uint32_t src, int depth) {
    const std::string a = named('r', dst), b = named('r', src), ga = named('g', dst), gb = named('g', src),
                      ca = named('c', dst), cb = named('c', src);
    switch (op) {
      case layout::OP_ADD:
        line(depth, "if (wantColour) { float wa = max(" + a + ", 0.0), wb = max(" + b +
                        ", 0.0); float w = wa + wb; if (w > 0.0) " + ca + " = (" + ca + " * wa + " + cb + " * wb) / w; }");
        line(depth, a + " = " + a + " + " + b + "; " + ga + " = " + ga + " + " + gb + ";");
        break;
      case layout::OP_MAX:
        line(depth, "if (" + b + " > " + a + ") { " + ca + " = " + cb + "; " + ga + " = " + gb + "; }");
        line(depth, a + " = max(" + a + ", " + b + ");");
        break;
      case layout::OP_MIN:
        line(depth, "if (" + b + " < " + a + ") { " + ca + " = " + cb + "; " + ga + " = " + gb + "; }");
        line(depth, a + " = min(" + a + ", " + b + ");");
        break;
      case layout::OP_DIFF:
        line(depth, "{ float cut = 1.0 - " + b + "; if (cut < " + a + ") { " + ca + " = " + cb + "; " + ga + " = -" + gb +
                        "; } " + a + " = min(" + a + ", cut); }");
        break;
      case layout::OP_SDIFF:
        line(depth, "{ float keep = 1.0 - " + b + "; if (keep < " + a + ") " + ca + " = " + cb + "; " + ga + " = " + ga +
                        " * keep - " + gb + " * " + a + "; " + a + " = " + a + " * keep; }");
        break;
      default:  // OP_MUL
        line(depth, "if (" + b + " < " + a + ") " + ca + " = " + cb + ";");
        line(depth, ga + " = " + ga + " * " + b + " + " + gb + " * " + a + "; " + a + " = " + a + " * " + b + ";");
        break;
    }
  }

  void warp(const layout::uvec4& in, int depth) {
    const std::uint32_t dst = in.x >> 8, z = in.z;
    check(dst != 0 && dst < p_.pointRegisters, "a warp's point register is out of range");
    check(in.y < p_.warps.size(), "warp index out of range");
    const auto& w = p_.warps[in.y];
    // Point register 0's Jacobian: the identity, its zeros Z.
    const std::string jz = z == 0 ? "vec3(1.0, Z, Z), vec3(Z, 1.0, Z), vec3(Z, Z, 1.0)"
                                  : named3("ja", z) + ", " + named3("jb", z) + ", " + named3("jc", z);
    line(depth, "{ precise mat3 jin = transpose(mat3(" + jz + "));");
    std::string at = point(z);
    if (w.meta.w != 0) {
      check(w.meta.w < p_.matrices.size(), "matrix index out of range");
      const auto& m = p_.matrices[w.meta.w];
      at = "toLocalRows(" + rows(w.meta.w) + ", " + at + ")";
      line(depth + 1, "jin = transpose(mat3(" + v3(m.r0) + ", " + v3(m.r1) + ", " + v3(m.r2) + ")) * jin;");
    }
    // Z for the warp's Jacobian's zeros (its identity entries the warp leaves).
    line(depth + 1, point(dst) + " = warpJacobianOf(" + std::to_string(w.meta.x) + "u, " + std::to_string(w.meta.y) + "u, " +
                        std::to_string(w.meta.z) + "u, " + v4(w.params) + ", " + at + ", jin, Z, " + named3("ja", dst) +
                        ", " + named3("jb", dst) + ", " + named3("jc", dst) + "); }");
  }

  // Instructions [begin, end): a skip's subtree is a block the subgroup enters unless all its
  // lanes are outside (branchOnSkips), else it always runs and outside lanes get zeros after it,
  // as in the field generator (the subtree writes only registers that are dead once it is done).
  void emitRange(std::uint32_t begin, std::uint32_t end, int depth) {
    const std::uint32_t regs = std::max<std::uint32_t>(p_.fieldRegisters, 1);
    for (std::uint32_t pc = begin; pc < end; ++pc) {
      const auto& in = p_.code[pc].code;
      const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
      check(in.z < p_.pointRegisters, "point register out of range");
      switch (op) {
        case layout::OP_PRIM: {
          check(dst < regs, "field register out of range");
          const std::uint32_t run = nullAddRun(pc, end);
          if (run >= kMinNullAddRun) {
            nullAdds(pc, run, depth);
            pc += 2 * run - 1;
          } else {
            primitive(in, depth);
          }
          break;
        }
        case layout::OP_ADD:
        case layout::OP_MAX:
        case layout::OP_MIN:
        case layout::OP_DIFF:
        case layout::OP_SDIFF:
        case layout::OP_MUL:
          check(dst < regs && in.y < regs, "field register out of range");
          combine(op, dst, in.y, depth);
          break;
        case layout::OP_ONE_MINUS:
          check(dst < regs, "field register out of range");
          line(depth, named('r', dst) + " = 1.0 - " + named('r', dst) + "; " + named('g', dst) + " = -" + named('g', dst) + ";");
          break;
        case layout::OP_POW: {
          check(dst < regs, "field register out of range");
          // The exponent from the instruction, as the field code reads it; pow(0, y) is 0 (y > 0).
          const std::string d = named('r', dst), g = named('g', dst);
          line(depth, "{ float base = max(" + d + ", 0.0); float e = uintBitsToFloat(" + std::string(codeArray_) + "[" +
                          std::to_string(pc) + "].w); " + d + " = powField(base, e);");
          line(depth + 1, "precise float derivative = base > 0.0 ? e * " + d + " / base : 0.0; " + g + " = " + g +
                              " * derivative; }");
          break;
        }
        case layout::OP_WARP:
          warp(in, depth);
          break;
        case layout::OP_SKIP: {
          check(dst < regs, "field register out of range");
          check(in.y < p_.boxes.size(), "box index out of range");
          const std::uint32_t target = in.w;
          check(target > pc && target <= end, "skip target out of its range");
          const auto& box = p_.boxes[in.y];
          const std::string zero = named('r', dst) + " = 0.0; " + named('g', dst) + " = vec3(0.0); " + named('c', dst) +
                                   " = vec3(0.0);";
          if (in.z == 0 && regionMissesBox(options_.region, box)) {
            line(depth, zero + "  // pruned: outside the region");
            pc = target - 1;
            break;
          }
          const std::string o = "out" + std::to_string(pc);
          line(depth, "{");
          line(depth + 1, "bool " + o + " = outsideBoxBounds(" + vec3Lit(box.lo) + ", " + vec3Lit(box.hi) + ", " +
                              point(warps_ ? in.z : 0) + ");");
          if (options_.branchOnSkips && target - pc - 1 >= options_.minBranchInstructions) {
            line(depth + 1, "while (!subgroupAll(" + o + ")) {");
            line(depth + 2, "EVAL_LOOP_TICK();");
            emitRange(pc + 1, target, depth + 2);
            line(depth + 2, "break;");
            line(depth + 1, "}");
          } else {
            emitRange(pc + 1, target, depth + 1);
          }
          line(depth + 1, "if (" + o + ") { " + zero + " }");
          line(depth, "}");
          pc = target - 1;
          break;
        }
        default:
          throw std::invalid_argument("specialised gradient: unknown opcode " + std::to_string(op));
      }
    }
  }

  const blobtree::Program& p_;
  const CodegenOptions& options_;
  const char* codeArray_;
  bool warps_ = false;
  std::string out_;
};

}  // namespace

std::string generateSpecialisedGradient(const blobtree::Program& program, const CodegenOptions& options,
                                        const char* codeArray) {
  GradientGenerator generator(program, options, codeArray);
  return generator.supported() ? generator.function() : std::string();
}

}  // namespace blobvk::vk
