#include "blobvk/vk/eval/program_codegen_loops.h"

#include "blobvk/vk/eval/codegen_text.h"

#include <map>
#include <utility>
#include <vector>

namespace blobvk::vk {
namespace {

using namespace codegen;

// Where the text being generated lives: the kernel's entry functions (record values as
// literals, pruned to the region) or a shape's function (values the instances share as literals,
// the others loaded from the instance's block at `b`, in CodeShapes' word order).
struct Context {
  bool colour = false;
  bool function = false;
  std::uint32_t shape = 0;
  std::uint32_t word = 0;    // own words met so far
  std::uint32_t loaded = 0;  // block words used so far
  std::uint32_t reg0 = 0, point0 = 0;
  std::uint32_t skips = 0;
  std::string text;
};

class LoopedGenerator {
 public:
  LoopedGenerator(const blobtree::Program& p, const CodeShapes& s, const CodegenOptions& o)
      : p_(p), s_(s), o_(o), data0_(std::to_string(p.code.size()) + "u") {
    if (o_.region.valid) {
      // Prefix counts of the instructions the region prunes (a box skip or primitive on the world
      // point whose box misses it): an element with none inside is whole in the region.
      pruned_.assign(p.code.size() + 1, 0);
      for (std::size_t pc = 0; pc < p.code.size(); ++pc) {
        const auto& in = p.code[pc].code;
        const std::uint32_t op = in.x & 0xffu;
        bool miss = false;
        if (in.z == 0 && op == layout::OP_SKIP) miss = regionMissesBox(o_.region, p.boxes[in.y]);
        if (in.z == 0 && op == layout::OP_PRIM && in.y < p.primitiveBoxes.size())
          miss = regionMissesBox(o_.region, p.primitiveBoxes[in.y]);
        pruned_[pc + 1] = pruned_[pc] + (miss ? 1u : 0u);
      }
    }
  }

  std::string run(std::uint32_t* emitted) {
    const std::string mains = entry(false) + entry(true);
    std::string out;
    if (usesData_)
      out += "// Record values of repeated shapes' instances, after the program's instructions.\n"
             "layout(std430, set = PROGRAM_SET, binding = PROGRAM_BINDING + 0) readonly buffer SpecialisedData {\n"
             "  uvec4 D[];\n};\n\n";
    for (const auto& [key, text] : functions_) out += text;  // inner shapes have lower ids
    out += mains;
    if (emitted) *emitted = emitted_;
    return out;
  }

 private:
  static std::string named(char prefix, std::uint32_t n) {
    std::string s(1, prefix);
    s.append(std::to_string(n));
    return s;
  }
  static std::string indent(int depth) { return std::string(std::size_t(depth) * 2, ' '); }
  static std::string reg(const Context& c, std::uint32_t r) { return named('r', r - c.reg0); }
  static std::string col(const Context& c, std::uint32_t r) { return named('c', r - c.reg0); }
  static std::string point(const Context& c, std::uint32_t q) { return q == c.point0 ? "p" : named('q', q - c.point0); }
  static void line(Context& c, int depth, const std::string& s) { c.text += indent(depth) + s + "\n"; }
  void count(const Context& c) {
    if (!c.colour) ++emitted_;
  }

  std::vector<Word> words(Context& c, std::uint32_t pc) {
    std::vector<layout::uvec4> raw;
    CodeShapes::instructionWords(p_, pc, raw);
    std::vector<Word> out(raw.size());
    for (std::size_t i = 0; i < raw.size(); ++i) {
      out[i].bits = raw[i];
      if (c.function && !s_.literalWords(c.shape)[c.word++]) {
        out[i].load = "D[" + data0_ + " + b + " + std::to_string(c.loaded++) + "u]";
        usesData_ = true;
      }
    }
    return out;
  }

  std::string entry(bool colour) {
    Context c;
    c.colour = colour;
    // `precise` on the functions and colour registers: glslang makes every operation feeding them
    // NoContraction, so no driver fuses a * b + c (as in the unrolled generator; docs/vulkan.md).
    line(c, 0, colour ? "precise float evaluateFieldColour(vec3 p, uint n, out vec3 colour) {"
                      : "precise float evaluateField(vec3 p, uint n) {");
    declare(c, std::max<std::uint32_t>(p_.fieldRegisters, 1), p_.pointRegisters);
    expr(c, s_.root(), false, 1);
    if (colour) line(c, 1, "colour = c0;");
    line(c, 1, "return r0;");
    line(c, 0, "}\n");
    return std::move(c.text);
  }

  void declare(Context& c, std::uint32_t regs, std::uint32_t points) {
    for (std::uint32_t r = 0; r < regs; ++r) {
      line(c, 1, "float " + named('r', r) + " = 0.0;");
      if (c.colour) line(c, 1, "precise vec3 " + named('c', r) + " = vec3(0.0);");
    }
    for (std::uint32_t q = 1; q < points; ++q) line(c, 1, "vec3 " + named('q', q) + " = p;");
  }

  // The shape's function (field or colour variant), generated once.
  std::string function(std::uint32_t shape, bool colour) {
    const std::string name = named('s', shape) + (colour ? "c" : "f");
    const auto key = std::make_pair(shape, colour);
    if (functions_.count(key)) return name;
    functions_[key];  // reserved
    bool head = false;
    const std::int32_t ei = s_.representative(shape, head);
    const CodeExpr& e = s_.exprs()[std::size_t(ei)];
    Context c;
    c.colour = colour;
    c.function = true;
    c.shape = shape;
    c.reg0 = e.reg;
    c.point0 = e.point;
    line(c, 0, "precise float " + name + (colour ? "(vec3 p, uint b, out vec3 colour) {" : "(vec3 p, uint b) {"));
    declare(c, e.regsUsed, e.pointsUsed);
    expr(c, ei, head, 1);
    if (colour) line(c, 1, "colour = c0;");
    line(c, 1, "return r0;");
    line(c, 0, "}\n");
    functions_[key] = std::move(c.text);
    return name;
  }

  // Code computing expression ei (or its head) into its register.
  void expr(Context& c, std::int32_t ei, bool head, int depth) {
    const CodeExpr& e = s_.exprs()[std::size_t(ei)];
    const auto& loops = s_.loops(ei);
    const std::size_t limit = head ? e.headTails : e.tails.size();
    std::size_t t = 0, li = 0;
    if (!head && !loops.empty() && loops[0].withHead) {
      run(c, ei, loops[0], depth);
      t = loops[0].endTail;
      li = 1;
    } else {
      atom(c, ei, depth);
    }
    while (t < limit) {
      if (!head && li < loops.size() && loops[li].firstTail == t) {
        run(c, ei, loops[li], depth);
        t = loops[li].endTail;
        ++li;
        continue;
      }
      const CodeExpr::Tail& tail = e.tails[t];
      const auto& in = p_.code[tail.pc].code;
      if (tail.child < 0) {
        line(c, depth, unaryLine(in.x & 0xffu, reg(c, e.reg), in.w));
      } else {
        expr(c, tail.child, false, depth);
        c.text += combineLines(in.x & 0xffu, reg(c, e.reg), col(c, e.reg), reg(c, e.reg + 1), col(c, e.reg + 1),
                               c.colour, indent(depth));
      }
      count(c);
      ++t;
    }
  }

  void atom(Context& c, std::int32_t ei, int depth) {
    const CodeExpr& e = s_.exprs()[std::size_t(ei)];
    const auto& in = p_.code[e.begin].code;
    const std::vector<Word> w = words(c, e.begin);
    const std::string d = reg(c, e.reg), cd = col(c, e.reg), at = point(c, e.point);
    const bool world = !c.function && e.point == 0;
    count(c);
    switch (in.x & 0xffu) {
      case layout::OP_PRIM: {
        const auto& prim = p_.primitives[in.y];
        const std::size_t m = prim.meta.y != 0 ? 3 : 0;
        if (world && in.y < p_.primitiveBoxes.size() && regionMissesBox(o_.region, p_.primitiveBoxes[in.y])) {
          line(c, depth, d + " = 0.0;  // pruned: the primitive is 0 in the region");
        } else {
          const std::string local = m ? toLocal(w[0], w[1], w[2], at) : at;
          line(c, depth, d + " = " + primitiveField(prim.meta.x, local, w[m], w[m + 1], w[m + 2]) + ";");
        }
        if (c.colour) line(c, depth, cd + " = unpackColour(" + w[m + 3].colour() + ");");
        return;
      }
      case layout::OP_SKIP: {
        const std::string zero = d + " = 0.0;" + (c.colour ? " " + cd + " = vec3(0.0);" : std::string());
        if (world && regionMissesBox(o_.region, p_.boxes[in.y])) {
          line(c, depth, zero + "  // pruned: outside the region");
          return;
        }
        const std::string o = named('o', c.skips++);
        line(c, depth, "{");
        line(c, depth + 1, "bool " + o + " = outsideBoxBounds(" + w[0].v3() + ", " + w[1].v3() + ", " + at + ");");
        const CodeExpr& body = s_.exprs()[std::size_t(e.body)];
        if (o_.branchOnSkips && body.end - body.begin >= o_.minBranchInstructions) {
          // A loop rather than an `if`: the subgroup leaves it as soon as no lane is active.
          line(c, depth + 1, "while (!subgroupAll(" + o + ")) {");
          line(c, depth + 2, "EVAL_LOOP_TICK();");
          expr(c, e.body, false, depth + 2);
          line(c, depth + 2, "break;");
          line(c, depth + 1, "}");
        } else {
          expr(c, e.body, false, depth + 1);
        }
        line(c, depth + 1, "if (" + o + ") { " + zero + " }");
        line(c, depth, "}");
        return;
      }
      default: {  // OP_WARP
        const auto& warp = p_.warps[in.y];
        const std::size_t m = warp.meta.w != 0 ? 3 : 0;
        const std::string local = m ? toLocal(w[0], w[1], w[2], at) : at;
        line(c, depth, point(c, e.point + 1) + " = " + warpPoint(warp.meta.x, warp.meta.y, warp.meta.z, local, w[m]) + ";");
        expr(c, e.body, false, depth);
        return;
      }
    }
  }

  struct Element {
    std::int32_t expr;
    bool head;
  };

  // A run of equal siblings: one loop in a function; in the entry functions one loop per stretch
  // of elements the region leaves whole, the others inline (pruned where they miss it).
  void run(Context& c, std::int32_t owner, const CodeRun& r, int depth) {
    const CodeExpr& e = s_.exprs()[std::size_t(owner)];
    std::vector<Element> elements;
    if (r.withHead) elements.push_back({owner, true});
    for (std::uint32_t t = r.firstTail; t < r.endTail; ++t) elements.push_back({e.tails[t].child, false});
    const std::uint32_t combine = p_.code[e.tails[r.firstTail].pc].code.x & 0xffu;
    if (c.function) {
      loop(c, e, r.shape, combine, "b + " + std::to_string(c.loaded) + "u", std::uint32_t(elements.size()), r.withHead,
           depth);
      c.loaded += r.count() * s_.blockWords(r.shape);
      return;
    }
    auto whole = [&](const Element& el) {
      if (!o_.region.valid) return true;
      const CodeExpr& x = s_.exprs()[std::size_t(el.expr)];
      const std::uint32_t end = el.head ? x.headEnd : x.end;
      return pruned_[end] == pruned_[x.begin];
    };
    std::size_t i = 0;
    while (i < elements.size()) {
      std::size_t j = i;
      while (j < elements.size() && whole(elements[j])) ++j;
      if (j - i >= std::max<std::uint32_t>(o_.loops.minCount, 2)) {
        const Element& first = elements[i];
        const std::uint32_t offset = first.head ? s_.headOffset(first.expr) : s_.childOffset(first.expr);
        loop(c, e, r.shape, combine, std::to_string(offset) + "u", std::uint32_t(j - i), first.head, depth);
        i = j;
        continue;
      }
      const std::size_t stop = std::max(j, i + 1);
      for (; i < stop; ++i) {
        const Element& el = elements[i];
        expr(c, el.expr, el.head, depth);
        if (!el.head) {
          c.text += combineLines(combine, reg(c, e.reg), col(c, e.reg), reg(c, e.reg + 1), col(c, e.reg + 1), c.colour,
                                 indent(depth));
          count(c);
        }
      }
    }
  }

  // for each instance: its value from the shape's function, combined into e's register (the
  // first one, when it is e's head, assigned).
  void loop(Context& c, const CodeExpr& e, std::uint32_t shape, std::uint32_t combine, const std::string& base,
            std::uint32_t n, bool withHead, int depth) {
    const std::string fn = function(shape, c.colour);
    const std::string d = reg(c, e.reg), cd = col(c, e.reg);
    const std::string stride = std::to_string(s_.blockWords(shape)) + "u";
    usesData_ = true;
    line(c, depth, "for (uint i = 0u, count = " + std::to_string(n) + "u + D[" + data0_ + "].x; i < count; ++i) {");
    line(c, depth + 1, "EVAL_LOOP_TICK();");
    if (c.colour)
      line(c, depth + 1, "vec3 cv; float v = " + fn + "(" + point(c, e.point) + ", " + base + " + i * " + stride + ", cv);");
    else
      line(c, depth + 1, "float v = " + fn + "(" + point(c, e.point) + ", " + base + " + i * " + stride + ");");
    const std::string combined = combineLines(combine, d, cd, "v", "cv", c.colour, indent(depth + 2));
    if (withHead) {
      line(c, depth + 1, "if (i == 0u) { " + d + " = v;" + (c.colour ? " " + cd + " = cv;" : std::string()) + " } else {");
      c.text += combined;
      line(c, depth + 1, "}");
    } else {
      c.text += combineLines(combine, d, cd, "v", "cv", c.colour, indent(depth + 1));
    }
    line(c, depth, "}");
    count(c);
  }

  const blobtree::Program& p_;
  const CodeShapes& s_;
  const CodegenOptions& o_;
  const std::string data0_;
  std::vector<std::uint32_t> pruned_;
  std::map<std::pair<std::uint32_t, bool>, std::string> functions_;
  bool usesData_ = false;
  std::uint32_t emitted_ = 0;
};

}  // namespace

std::string generateLoopedEvaluators(const blobtree::Program& program, const CodeShapes& shapes,
                                     const CodegenOptions& options, std::uint32_t* emitted) {
  return LoopedGenerator(program, shapes, options).run(emitted);
}

}  // namespace blobvk::vk
