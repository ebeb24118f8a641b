#include "blobvk/vk/eval/stack_program.h"

#include <stdexcept>
#include <string>

namespace blobvk::vk {
namespace {

struct TreeNode {
  std::uint32_t kind = 0, op = 0, payload = 0, point = 0;
  std::vector<int> children;
};

struct PointDef {
  std::uint32_t warp = 0, src = 0;
};

class Builder {
 public:
  explicit Builder(const blobtree::Program& p) : program_(p) {}

  std::vector<layout::Instruction> build() {
    std::vector<int> reg(layout::MAX_FIELD_REGISTERS, -1);
    std::vector<PointDef> points(layout::MAX_POINT_REGISTERS);
    struct Pending {
      std::uint32_t dst, box, point, end;
      std::vector<PointDef> points;  // warp definitions when the skip ran
    };
    std::vector<Pending> pending;
    const std::size_t n = program_.code.size();
    for (std::size_t pc = 0; pc <= n; ++pc) {
      while (!pending.empty() && pending.back().end == pc) {
        const Pending s = pending.back();
        pending.pop_back();
        const int box = add({TREE_BOX, 0, s.box, s.point, {reg.at(s.dst)}});
        reg[s.dst] = wrapWarps(box, s.point, s.points);
      }
      if (pc == n) break;
      const layout::uvec4 in = program_.code[pc].code;
      const std::uint32_t op = in.x & 0xffu, dst = in.x >> 8;
      switch (op) {
        case layout::OP_PRIM:
          reg.at(dst) = wrapWarps(add({TREE_LEAF, 0, in.y, in.z, {}}), in.z, points);
          break;
        case layout::OP_ADD:
        case layout::OP_MAX:
        case layout::OP_MIN:
        case layout::OP_DIFF:
        case layout::OP_SDIFF:
        case layout::OP_MUL: {
          const int a = reg.at(dst), b = reg.at(in.y);
          // acc = op(op(a, b), c) is the n-ary fold op(a, b, c): same operations, same order.
          if (nodes_[a].kind == TREE_OP && nodes_[a].op == op) {
            nodes_[a].children.push_back(b);
          } else {
            reg[dst] = add({TREE_OP, op, 0, 0, {a, b}});
          }
          break;
        }
        case layout::OP_POW:
        case layout::OP_ONE_MINUS:
          reg.at(dst) = add({TREE_UNARY, op, op == layout::OP_POW ? in.w : 0u, 0, {reg.at(dst)}});
          break;
        case layout::OP_WARP:
          points.at(dst) = {in.y, in.z};
          break;
        case layout::OP_SKIP:
          pending.push_back({dst, in.y, in.z, in.w, points});
          break;
        default:
          throw std::invalid_argument("stack-based traversal: unknown opcode " + std::to_string(op));
      }
    }
    if (n == 0) return {};
    // Emit in pre-order so the root is node 0.
    std::vector<layout::Instruction> out;
    emit(reg[0], out, 1);
    return out;
  }

 private:
  int add(TreeNode node) {
    nodes_.push_back(std::move(node));
    return int(nodes_.size() - 1);
  }

  // Wraps `node` in the warp nodes that compute point register `point` from point 0: the
  // outermost node runs first.
  int wrapWarps(int node, std::uint32_t point, const std::vector<PointDef>& defs) {
    while (point != 0) {
      const PointDef& d = defs.at(point);
      node = add({TREE_WARP, 0, d.warp, point | (d.src << 8), {node}});
      point = d.src;
    }
    return node;
  }

  std::uint32_t emit(int node, std::vector<layout::Instruction>& out, std::uint32_t depth) {
    if (depth > kMaxTreeDepth) {
      throw std::invalid_argument("stack-based traversal: tree deeper than " +
                                  std::to_string(kMaxTreeDepth) + " levels");
    }
    const TreeNode& t = nodes_[node];
    const std::uint32_t self = std::uint32_t(out.size() / 2);
    out.push_back({{t.kind | (t.op << 8), t.payload, t.point, 0}});
    out.push_back({{~0u, ~0u, 0, 0}});
    std::uint32_t previous = ~0u;
    for (int child : t.children) {
      const std::uint32_t c = emit(child, out, depth + 1);
      if (previous == ~0u) out[2 * self + 1].code.x = c;
      else out[2 * previous + 1].code.y = c;
      previous = c;
    }
    return self;
  }

  const blobtree::Program& program_;
  std::vector<TreeNode> nodes_;
};

}  // namespace

std::vector<layout::Instruction> buildStackProgram(const blobtree::Program& program) {
  return Builder(program).build();
}

}  // namespace blobvk::vk
