#include "blobvk/vk/eval/program_shape.h"

#include <algorithm>
#include <cstring>
#include <functional>
#include <map>

namespace blobvk::vk {

using layout::uvec4;

namespace {
uvec4 bits(const layout::vec4& v) {
  uvec4 u;
  std::memcpy(&u, &v, sizeof u);
  return u;
}
bool equal(const uvec4& a, const uvec4& b) { return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w; }
bool isCombine(std::uint32_t op) {
  return op == layout::OP_ADD || op == layout::OP_MAX || op == layout::OP_MIN || op == layout::OP_DIFF ||
         op == layout::OP_SDIFF || op == layout::OP_MUL;
}
}  // namespace

// Recursive descent over the grammar compile() emits (blobtree/compile.cpp's emit()):
//   value(r, q) := atom(r, q) tail(r, q)*
//   atom(r, q)  := PRIM r@q | SKIP r@q value(r, q) (up to the skip target) | WARP q+1<-q value(r, q+1)
//   tail(r, q)  := ONE_MINUS r | POW r | value(r + 1, q) COMBINE r, r+1
class CodeParser {
 public:
  CodeParser(const blobtree::Program& p, CodeShapes& s) : p_(p), s_(s) {}

  bool run() {
    std::uint32_t pc = 0;
    const std::int32_t root = parse(pc, std::uint32_t(p_.code.size()), 0, 0, 0);
    if (root < 0 || pc != p_.code.size()) return false;
    s_.root_ = root;
    return true;
  }

 private:
  static std::uint32_t op(const layout::Instruction& in) { return in.code.x & 0xffu; }
  static std::uint32_t dst(const layout::Instruction& in) { return in.code.x >> 8; }

  // Whether the instruction at pc can start a child value at (r + 1, q).
  bool startsChild(std::uint32_t pc, std::uint32_t r, std::uint32_t q) const {
    const auto& in = p_.code[pc];
    const std::uint32_t o = op(in);
    if (o == layout::OP_PRIM || o == layout::OP_SKIP) return dst(in) == r + 1 && in.code.z == q;
    return o == layout::OP_WARP && in.code.z == q;
  }

  std::int32_t parse(std::uint32_t& pc, std::uint32_t limit, std::uint32_t r, std::uint32_t q, std::uint32_t depth) {
    if (pc >= limit || depth > 20000 || r >= p_.fieldRegisters || q >= p_.pointRegisters) return -1;
    CodeExpr e;
    e.begin = pc;
    e.reg = r;
    e.point = q;
    const auto& in = p_.code[pc];
    const std::uint32_t o = op(in);
    std::vector<std::uint32_t> key{o};
    if (o == layout::OP_PRIM) {
      if (dst(in) != r || in.code.z != q || in.code.y >= p_.primitives.size()) return -1;
      const auto& prim = p_.primitives[in.code.y];
      if (prim.meta.y >= p_.matrices.size()) return -1;
      key.push_back(prim.meta.x);
      key.push_back(prim.meta.y != 0);
      ++pc;
    } else if (o == layout::OP_SKIP) {
      const std::uint32_t target = in.code.w;
      if (dst(in) != r || in.code.z != q || in.code.y >= p_.boxes.size() || target <= pc + 1 || target > limit) return -1;
      ++pc;
      e.body = parse(pc, target, r, q, depth + 1);
      if (e.body < 0 || pc != target) return -1;
    } else if (o == layout::OP_WARP) {
      if (dst(in) != q + 1 || in.code.z != q || in.code.y >= p_.warps.size()) return -1;
      const auto& w = p_.warps[in.code.y];
      if (w.meta.w >= p_.matrices.size()) return -1;
      key.insert(key.end(), {w.meta.x, w.meta.y, w.meta.z, w.meta.w != 0});
      ++pc;
      e.body = parse(pc, limit, r, q + 1, depth + 1);
      if (e.body < 0) return -1;
    } else {
      return -1;
    }
    if (e.body >= 0) {
      const CodeExpr& b = s_.exprs_[std::size_t(e.body)];
      key.push_back(b.shape);
      e.regsUsed = std::max(e.regsUsed, b.reg - r + b.regsUsed);
      e.pointsUsed = std::max(e.pointsUsed, b.point - q + b.pointsUsed);
    }
    bool sawChild = false;
    while (pc < limit) {
      const auto& t = p_.code[pc];
      const std::uint32_t to = op(t);
      if ((to == layout::OP_ONE_MINUS || to == layout::OP_POW) && dst(t) == r) {
        key.insert(key.end(), {1000u + to, to == layout::OP_POW ? t.code.w : 0u});
        e.tails.push_back({pc, -1});
        if (!sawChild) ++e.headTails;
        ++pc;
        continue;
      }
      if (!startsChild(pc, r, q)) break;
      if (!sawChild) {
        e.headEnd = pc;
        e.headShape = intern(key, pc - e.begin);
      }
      sawChild = true;
      const std::int32_t child = parse(pc, limit, r + 1, q, depth + 1);
      if (child < 0 || pc >= limit) return -1;
      const auto& c = p_.code[pc];
      if (!isCombine(op(c)) || dst(c) != r || c.code.y != r + 1) return -1;
      const CodeExpr& ce = s_.exprs_[std::size_t(child)];
      key.insert(key.end(), {2000u + op(c), ce.shape});
      e.regsUsed = std::max(e.regsUsed, 1 + ce.regsUsed);
      e.pointsUsed = std::max(e.pointsUsed, ce.pointsUsed);
      e.tails.push_back({pc, child});
      ++pc;
    }
    e.end = pc;
    e.shape = intern(key, e.end - e.begin);
    if (!sawChild) {
      e.headEnd = e.end;
      e.headShape = e.shape;
    }
    s_.exprs_.push_back(std::move(e));
    return std::int32_t(s_.exprs_.size() - 1);
  }

  std::uint32_t intern(const std::vector<std::uint32_t>& key, std::uint32_t instructions) {
    auto [it, added] = shapes_.try_emplace(key, std::uint32_t(s_.shapeInstructions_.size()));
    if (added) s_.shapeInstructions_.push_back(instructions);
    return it->second;
  }

  const blobtree::Program& p_;
  CodeShapes& s_;
  std::map<std::vector<std::uint32_t>, std::uint32_t> shapes_;
};

void CodeShapes::instructionWords(const blobtree::Program& p, std::uint32_t pc, std::vector<uvec4>& out) {
  const auto& in = p.code[pc].code;
  auto matrix = [&](std::uint32_t m) {
    if (m == 0) return;
    out.push_back(bits(p.matrices[m].r0));
    out.push_back(bits(p.matrices[m].r1));
    out.push_back(bits(p.matrices[m].r2));
  };
  switch (in.x & 0xffu) {
    case layout::OP_PRIM: {
      const auto& prim = p.primitives[in.y];
      matrix(prim.meta.y);
      out.push_back(bits(prim.p0));
      out.push_back(bits(prim.p1));
      out.push_back(bits(prim.p2));
      out.push_back({prim.meta.z, 0u, 0u, 0u});
      break;
    }
    case layout::OP_SKIP:
      out.push_back(bits(p.boxes[in.y].lo));
      out.push_back(bits(p.boxes[in.y].hi));
      break;
    case layout::OP_WARP:
      matrix(p.warps[in.y].meta.w);
      out.push_back(bits(p.warps[in.y].params));
      break;
    default:
      break;
  }
}

std::unique_ptr<CodeShapes> CodeShapes::analyse(const blobtree::Program& program, const LoopOptions& loops) {
  std::unique_ptr<CodeShapes> s(new CodeShapes(program));
  if (program.code.empty() || !CodeParser(program, *s).run()) return nullptr;
  s->findLoops(loops);
  s->decideLiterals();
  s->blockWords_.assign(s->shapeCount(), 0);
  for (std::uint32_t shape = 0; shape < s->shapeCount(); ++shape) s->blockWords_[shape] = s->computeBlockWords(shape);
  s->childOffset_.assign(s->exprs_.size(), 0);
  s->headOffset_.assign(s->exprs_.size(), 0);
  // Word 0 is a zero the loops add to their trip counts: counts the compiler cannot see keep
  // NIR and LLVM from unrolling the loops back into the code they replace.
  s->data_.push_back({0u, 0u, 0u, 0u});
  s->layoutLiteral(s->root_);
  if (s->data_.size() == 1) s->data_.clear();  // no loops
  return s;
}

void CodeShapes::findLoops(const LoopOptions& options) {
  loops_.assign(exprs_.size(), {});
  representative_.assign(shapeCount(), 0);
  std::vector<bool> called(shapeCount(), false);
  for (std::size_t ei = 0; ei < exprs_.size(); ++ei) {
    const CodeExpr& e = exprs_[ei];
    representative_[e.shape] = std::int32_t(ei);
    std::uint32_t t = e.headTails;
    while (t < e.tails.size()) {
      const std::uint32_t shape = exprs_[std::size_t(e.tails[t].child)].shape;
      const std::uint32_t combine = program_.code[e.tails[t].pc].code.x & 0xffu;
      std::uint32_t u = t + 1;
      while (u < e.tails.size() && e.tails[u].child >= 0 && exprs_[std::size_t(e.tails[u].child)].shape == shape &&
             (program_.code[e.tails[u].pc].code.x & 0xffu) == combine)
        ++u;
      CodeRun run{t, u, t == e.headTails && e.headShape == shape, shape};
      if (run.count() >= options.minCount &&
          std::uint64_t(run.count()) * shapeInstructions_[shape] >= options.minInstructions) {
        loops_[ei].push_back(run);
        called[shape] = true;
      }
      // Unary tails between children end a stretch; skip them.
      t = u;
      while (t < e.tails.size() && e.tails[t].child < 0) ++t;
    }
  }
  // Heads stand for their shape where no whole expression has it.
  for (std::size_t ei = 0; ei < exprs_.size(); ++ei)
    if (exprs_[ei].headShape != exprs_[ei].shape && called[exprs_[ei].headShape] &&
        exprs_[std::size_t(representative_[exprs_[ei].headShape])].shape != exprs_[ei].headShape)
      representative_[exprs_[ei].headShape] = -1 - std::int32_t(ei);
  literal_.assign(shapeCount(), {});
  for (std::uint32_t shape = 0; shape < shapeCount(); ++shape)
    if (!called[shape]) representative_[shape] = std::int32_t(exprs_.size());  // no function
}

namespace {
// Walks an instance's words in the generator's order: its atom's words, its body, its tails (a
// child inline or a loop over a run); `head` stops after the leading unary tails.
template <class Word, class Loop>
void walkInstance(const blobtree::Program& p, const std::vector<CodeExpr>& exprs,
                  const std::vector<std::vector<CodeRun>>& loops, std::int32_t ei, bool head, const Word& word,
                  const Loop& loop) {
  const CodeExpr& e = exprs[std::size_t(ei)];
  const auto& l = loops[std::size_t(ei)];
  const std::size_t limit = head ? e.headTails : e.tails.size();
  std::size_t t = 0, li = 0;
  if (!head && !l.empty() && l[0].withHead) {
    loop(ei, l[0]);
    t = l[0].endTail;
    li = 1;
  } else {
    std::vector<uvec4> words;
    CodeShapes::instructionWords(p, e.begin, words);
    for (const uvec4& w : words) word(w);
    if (e.body >= 0) walkInstance(p, exprs, loops, e.body, false, word, loop);
  }
  while (t < limit) {
    if (!head && li < l.size() && l[li].firstTail == t) {
      loop(ei, l[li]);
      t = l[li].endTail;
      ++li;
      continue;
    }
    if (e.tails[t].child >= 0) walkInstance(p, exprs, loops, e.tails[t].child, false, word, loop);
    ++t;
  }
}
}  // namespace

void CodeShapes::ownWords(std::int32_t expr, bool head, std::vector<uvec4>& out) const {
  walkInstance(program_, exprs_, loops_, expr, head, [&](const uvec4& w) { out.push_back(w); },
               [](std::int32_t, const CodeRun&) {});
}

void CodeShapes::decideLiterals() {
  // Every instance of a called shape: whole expressions of that shape and heads of it.
  std::vector<std::vector<uvec4>> first(shapeCount());
  std::vector<bool> seen(shapeCount(), false);
  auto visit = [&](std::int32_t ei, bool head, std::uint32_t shape) {
    if (representative_[shape] == std::int32_t(exprs_.size())) return;  // not called
    std::vector<uvec4> words;
    ownWords(ei, head, words);
    if (!seen[shape]) {
      seen[shape] = true;
      first[shape] = words;
      literal_[shape].assign(words.size(), true);
      return;
    }
    auto& lit = literal_[shape];
    for (std::size_t k = 0; k < words.size() && k < lit.size(); ++k)
      if (lit[k] && !equal(words[k], first[shape][k])) lit[k] = false;
  };
  for (std::size_t ei = 0; ei < exprs_.size(); ++ei) {
    visit(std::int32_t(ei), false, exprs_[ei].shape);
    if (exprs_[ei].headShape != exprs_[ei].shape) visit(std::int32_t(ei), true, exprs_[ei].headShape);
  }
}

std::uint32_t CodeShapes::computeBlockWords(std::uint32_t shape) {
  const std::int32_t rep = representative_[shape];
  if (rep == std::int32_t(exprs_.size())) return 0;
  const bool head = rep < 0;
  const std::int32_t ei = head ? -1 - rep : rep;
  std::uint32_t k = 0, words = 0;
  walkInstance(
      program_, exprs_, loops_, ei, head,
      [&](const uvec4&) {
        if (!literal_[shape][k++]) ++words;
      },
      [&](std::int32_t, const CodeRun& run) { words += run.count() * blockWords_[run.shape]; });
  return words;
}

// A run's instances get their data blocks in order: the head's, then each tail child's.
void CodeShapes::layoutRun(std::int32_t owner, const CodeRun& run) {
  const CodeExpr& e = exprs_[std::size_t(owner)];
  if (run.withHead) {
    headOffset_[std::size_t(owner)] = std::uint32_t(data_.size());
    layoutBlock(owner, true);
  }
  for (std::uint32_t t = run.firstTail; t < run.endTail; ++t) {
    childOffset_[std::size_t(e.tails[t].child)] = std::uint32_t(data_.size());
    layoutBlock(e.tails[t].child, false);
  }
}

void CodeShapes::layoutLiteral(std::int32_t expr) {
  walkInstance(
      program_, exprs_, loops_, expr, false, [](const uvec4&) {},
      [&](std::int32_t owner, const CodeRun& run) { layoutRun(owner, run); });
}

void CodeShapes::layoutBlock(std::int32_t expr, bool head) {
  const CodeExpr& x = exprs_[std::size_t(expr)];
  const std::uint32_t shape = head ? x.headShape : x.shape;
  std::uint32_t k = 0;
  walkInstance(
      program_, exprs_, loops_, expr, head,
      [&](const uvec4& w) {
        if (!literal_[shape][k++]) data_.push_back(w);
      },
      [&](std::int32_t owner, const CodeRun& run) { layoutRun(owner, run); });
}

}  // namespace blobvk::vk
