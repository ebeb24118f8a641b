// The register code of a Program read back as an expression tree whose structurally equal
// subtrees share a shape id, and the data layout that lets the specialised code generator
// (program_codegen.cpp) emit a repeated subtree once, as a function called in a loop over the
// record values of its instances.
//
// Why: unrolled straight-line code grows with the model, and glslang plus llvmpipe's LLVM grow
// faster than the code (a 3,000-instruction tower took two minutes and 2.5 GB to build). Models
// are mostly repeats (instances, grids of primitives): a loop over a run of equal siblings keeps
// the kernel the size of the distinct shapes, with the same float operations in the same order.
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::vk {

// One value of the register code, computed into field register `reg` at point register `point`:
// an atom (OP_PRIM; OP_SKIP over an inner expression; OP_WARP of the point then an inner
// expression) followed by tails, each either a unary op on the value (OP_ONE_MINUS, OP_POW) or a
// child expression computed one register up and combined into this one.
struct CodeExpr {
  struct Tail {
    std::uint32_t pc = 0;     // the unary op, or the combine after the child
    std::int32_t child = -1;  // >= 0: the child expression (an index into CodeShapes::exprs)
  };
  std::uint32_t begin = 0, end = 0;  // its instructions [begin, end)
  std::uint32_t reg = 0, point = 0;
  std::int32_t body = -1;            // OP_SKIP, OP_WARP: the inner expression
  std::vector<Tail> tails;
  std::uint32_t headTails = 0;  // leading unary tails: with the atom they form the "head"
  std::uint32_t headEnd = 0;    // end of the head's instructions
  std::uint32_t shape = 0;      // equal ids: equal code up to the record values (relative registers)
  std::uint32_t headShape = 0;  // the head's shape (== shape when there are no child tails)
  std::uint32_t regsUsed = 1;   // field registers it writes, counted from `reg`
  std::uint32_t pointsUsed = 1; // point registers it touches, counted from `point`
};

// A stretch of equal children of one expression, combined by one opcode: instances in a loop.
struct CodeRun {
  std::uint32_t firstTail = 0, endTail = 0;  // the expression's tails [firstTail, endTail)
  bool withHead = false;  // the expression's head is the run's first element (same shape)
  std::uint32_t shape = 0;
  std::uint32_t count() const { return endTail - firstTail + (withHead ? 1u : 0u); }
};

struct LoopOptions {
  bool enabled = true;  // false: every instruction unrolled (the generator's earlier form)
  // A run of equal siblings becomes a loop when it has at least this many elements and its
  // unrolled code at least minInstructions instructions (smaller runs stay unrolled: literals
  // fold and nothing is loaded).
  std::uint32_t minCount = 3;
  std::uint32_t minInstructions = 16;
  // Loops only for code of more than this many instructions (the program pruned to the kernel's
  // region); shorter code is unrolled. On llvmpipe every load in a loop is a loop over the lanes:
  // unrolled code runs many times faster there and builds in time while it is short, so CPU
  // drivers keep loops for programs whose unrolled build would outweigh a mesh
  // (defaultCodegenOptions). 0: loops wherever the shapes repeat.
  std::uint32_t minProgramInstructions = 0;
};

class CodeShapes {
 public:
  // Null when the code is not in the form compile() emits (the generator then unrolls it all).
  static std::unique_ptr<CodeShapes> analyse(const blobtree::Program& program, const LoopOptions& loops);

  const std::vector<CodeExpr>& exprs() const { return exprs_; }
  std::int32_t root() const { return root_; }
  std::uint32_t shapeCount() const { return std::uint32_t(shapeInstructions_.size()); }
  std::uint32_t shapeInstructions(std::uint32_t shape) const { return shapeInstructions_[shape]; }
  // The instance a called shape's function is generated from: an expression, or (head true) the
  // head of one.
  std::int32_t representative(std::uint32_t shape, bool& head) const {
    const std::int32_t r = representative_[shape];
    head = r < 0;
    return head ? -1 - r : r;
  }

  // The expression's child runs that are loops (in tail order).
  const std::vector<CodeRun>& loops(std::int32_t expr) const { return loops_[std::size_t(expr)]; }

  // 16-byte record words an instruction reads (matrix rows, skeleton, colour; box lo and hi;
  // warp matrix and parameters), in the order the generator reads them.
  static void instructionWords(const blobtree::Program& program, std::uint32_t pc, std::vector<layout::uvec4>& out);

  // Per shape called as a function: for each of its own words (those not inside a nested loop's
  // elements), whether it is the same in every instance (emitted as a literal) or loaded.
  const std::vector<bool>& literalWords(std::uint32_t shape) const { return literal_[shape]; }
  // Words of one instance's block in the data (its loaded own words and its loops' elements).
  std::uint32_t blockWords(std::uint32_t shape) const { return blockWords_[shape]; }

  // The data every loop reads: a zero word (added to trip counts), then element blocks,
  // consecutive for the elements of one run. Empty when there are no loops.
  const std::vector<layout::uvec4>& data() const { return data_; }
  // Offset in data() of an element's block: a child expression, or an expression's head.
  std::uint32_t childOffset(std::int32_t expr) const { return childOffset_[std::size_t(expr)]; }
  std::uint32_t headOffset(std::int32_t expr) const { return headOffset_[std::size_t(expr)]; }

 private:
  explicit CodeShapes(const blobtree::Program& program) : program_(program) {}
  void findLoops(const LoopOptions& options);
  // The instance's own words in order (elements of loops left out), appended to `out`.
  void ownWords(std::int32_t expr, bool head, std::vector<layout::uvec4>& out) const;
  void decideLiterals();
  std::uint32_t computeBlockWords(std::uint32_t shape);
  void layoutLiteral(std::int32_t expr);                  // an expression emitted with literals
  void layoutBlock(std::int32_t expr, bool head);         // an instance's block, appended to data_
  void layoutRun(std::int32_t owner, const CodeRun& run);  // a run's blocks, head then tails

  const blobtree::Program& program_;
  std::vector<CodeExpr> exprs_;
  std::int32_t root_ = -1;
  std::vector<std::uint32_t> shapeInstructions_;
  std::vector<std::int32_t> representative_;  // per shape: an expression (or a head, encoded -1 - expr)
  std::vector<std::vector<CodeRun>> loops_;
  std::vector<std::vector<bool>> literal_;
  std::vector<std::uint32_t> blockWords_;
  std::vector<layout::uvec4> data_;
  std::vector<std::uint32_t> childOffset_, headOffset_;

  friend class CodeParser;
};

}  // namespace blobvk::vk
