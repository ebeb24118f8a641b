// EditableTree: apply one edit, recompile, and bound the region that may have changed (see
// edit.h for why the region is exact).
#include "blobvk/blobtree/edit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace blobvk::blobtree {
namespace {

const char* kindName(const Node& n) {
  if (n.isPrimitive()) return "a primitive";
  if (n.isWarp()) return "a warp";
  return "an operator";
}

std::size_t minChildren(const Node& n) {
  if (n.isWarp()) return 1;
  const auto type = std::get<Operator>(n.kind).type;
  return type == OperatorType::Difference || type == OperatorType::SmoothDifference ? 2 : 1;
}

// Pre-order indices of the nodes along a path, root first, from the subtree sizes.
std::vector<std::size_t> preorderChain(const Node& root, const std::vector<CompiledNode>& nodes,
                                       const NodePath& path) {
  std::vector<std::size_t> chain{0};
  const Node* n = &root;
  std::size_t at = 0;
  for (std::size_t depth = 0; depth < path.size(); ++depth) {
    const std::size_t c = path[depth];
    if (c >= n->children.size()) {
      throw std::invalid_argument("no node at path " + toString(path) + ": the node at " +
                                  toString(NodePath(path.begin(), path.begin() + long(depth))) +
                                  " has " + std::to_string(n->children.size()) + " children");
    }
    std::size_t i = at + 1;
    for (std::size_t k = 0; k < c; ++k) i += nodes[i].subtreeSize;
    at = i;
    n = &n->children[c];
    chain.push_back(at);
  }
  return chain;
}

}  // namespace

bool Region::everything() const {
  return !empty() && std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x),
                               std::abs(hi.y), std::abs(hi.z)}) >= 1e29;
}

void Region::grow(const glm::dvec3& boxLo, const glm::dvec3& boxHi) {
  if (boxLo.x > boxHi.x || boxLo.y > boxHi.y || boxLo.z > boxHi.z) return;
  lo = glm::min(lo, boxLo);
  hi = glm::max(hi, boxHi);
}

std::string toString(const NodePath& path) {
  std::string s = "[";
  for (std::size_t i = 0; i < path.size(); ++i) s += (i ? ", " : "") + std::to_string(path[i]);
  return s + "]";
}

EditableTree::EditableTree(Node root, const CompileOptions& options)
    : root_(std::move(root)), options_(options) {
  program_ = compile(root_, options_, nodes_);
}

const Node& EditableTree::node(const NodePath& path) const {
  const Node* n = &root_;
  for (std::size_t depth = 0; depth < path.size(); ++depth) {
    if (path[depth] >= n->children.size()) {
      throw std::invalid_argument("no node at path " + toString(path) + ": the node at " +
                                  toString(NodePath(path.begin(), path.begin() + long(depth))) +
                                  " has " + std::to_string(n->children.size()) + " children");
    }
    n = &n->children[path[depth]];
  }
  return *n;
}

std::optional<NodePath> EditableTree::find(std::string_view id) const {
  std::vector<NodePath> found = findAll(id, 1);
  if (found.empty()) return std::nullopt;
  return std::move(found.front());
}

std::vector<NodePath> EditableTree::findAll(std::string_view id, std::size_t limit) const {
  // Iterative pre-order walk (trees may be thousands of levels deep).
  std::vector<NodePath> found;
  std::vector<std::pair<const Node*, NodePath>> todo{{&root_, {}}};
  while (!todo.empty() && found.size() < limit) {
    auto [n, path] = std::move(todo.back());
    todo.pop_back();
    if (n->id == id) found.push_back(path);
    for (std::size_t c = n->children.size(); c-- > 0;) {
      NodePath p = path;
      p.push_back(c);
      todo.emplace_back(&n->children[c], std::move(p));
    }
  }
  return found;
}

Region EditableTree::apply(const Edit& edit) {
  // Validates before touching the tree, then applies, remembering how to undo if the new tree
  // does not compile.
  const std::vector<std::size_t> chain = preorderChain(root_, nodes_, edit.path);
  Node* target = &root_;
  for (std::size_t c : edit.path) target = &target->children[c];
  const std::string where = "node " + toString(edit.path) + (target->id.empty() ? "" : " ('" + target->id + "')");
  const bool structural = std::holds_alternative<AddChild>(edit.change) ||
                          std::holds_alternative<RemoveChild>(edit.change);

  Node saved;  // the replaced node fields (Set*) or the removed child
  std::size_t structuralAt = 0;
  std::visit(
      [&](const auto& change) {
        using T = std::decay_t<decltype(change)>;
        if constexpr (std::is_same_v<T, SetTransform>) {
          saved.transform = target->transform;
          target->transform = change.transform;
        } else if constexpr (std::is_same_v<T, SetPrimitive>) {
          if (!target->isPrimitive()) throw std::invalid_argument(where + " is " + kindName(*target) + ", not a primitive");
          saved.kind = target->kind;
          target->kind = change.primitive;
        } else if constexpr (std::is_same_v<T, SetOperator>) {
          if (!target->isOperator()) throw std::invalid_argument(where + " is " + kindName(*target) + ", not an operator");
          const auto type = change.op.type;
          if ((type == OperatorType::Difference || type == OperatorType::SmoothDifference) &&
              target->children.size() < 2)
            throw std::invalid_argument(where + " has 1 child; a difference needs at least 2");
          saved.kind = target->kind;
          target->kind = change.op;
        } else if constexpr (std::is_same_v<T, SetWarp>) {
          if (!target->isWarp()) throw std::invalid_argument(where + " is " + kindName(*target) + ", not a warp");
          saved.kind = target->kind;
          target->kind = change.warp;
        } else if constexpr (std::is_same_v<T, SetNode>) {
          if (change.node.kind.index() != target->kind.index())
            throw std::invalid_argument(where + " is " + kindName(*target) + " and cannot become " + kindName(change.node));
          if (const auto* o = std::get_if<Operator>(&change.node.kind);
              o && (o->type == OperatorType::Difference || o->type == OperatorType::SmoothDifference) &&
              target->children.size() < 2)
            throw std::invalid_argument(where + " has 1 child; a difference needs at least 2");
          saved.kind = target->kind, saved.transform = target->transform, saved.id = target->id;
          target->kind = change.node.kind, target->transform = change.node.transform, target->id = change.node.id;
        } else if constexpr (std::is_same_v<T, AddChild>) {
          if (!target->isOperator())
            throw std::invalid_argument("cannot add a child to " + where + ": it is " + kindName(*target) +
                                        (target->isWarp() ? " (exactly one child)" : ""));
          structuralAt = std::min(change.at, target->children.size());
          target->children.insert(target->children.begin() + long(structuralAt), change.child);
        } else {
          if (target->isPrimitive()) throw std::invalid_argument(where + " is a primitive: it has no children");
          if (change.at >= target->children.size())
            throw std::invalid_argument(where + " has no child " + std::to_string(change.at) + " (it has " +
                                        std::to_string(target->children.size()) + ")");
          if (target->children.size() <= minChildren(*target))
            throw std::invalid_argument("cannot remove child " + std::to_string(change.at) + " of " + where +
                                        ": " + kindName(*target) + " of this type needs at least " +
                                        std::to_string(minChildren(*target)));
          structuralAt = change.at;
          saved = std::move(target->children[change.at]);
          target->children.erase(target->children.begin() + long(change.at));
        }
      },
      edit.change);

  std::vector<CompiledNode> nodes;
  Program program;
  try {
    program = compile(root_, options_, nodes);
  } catch (...) {
    std::visit(
        [&](const auto& change) {
          using T = std::decay_t<decltype(change)>;
          if constexpr (std::is_same_v<T, SetTransform>) target->transform = saved.transform;
          else if constexpr (std::is_same_v<T, AddChild>) target->children.erase(target->children.begin() + long(structuralAt));
          else if constexpr (std::is_same_v<T, RemoveChild>) target->children.insert(target->children.begin() + long(structuralAt), std::move(saved));
          else if constexpr (std::is_same_v<T, SetNode>) target->kind = saved.kind, target->transform = saved.transform, target->id = saved.id;
          else target->kind = saved.kind;
        },
        edit.change);
    throw;
  }

  // The ancestors keep their pre-order indices (everything before the edit is unchanged), so
  // `chain` indexes both the old and the new per-node bounds.
  Region region;
  std::size_t level = chain.size() - 1;
  region.grow(nodes_[chain[level]].lo, nodes_[chain[level]].hi);
  region.grow(nodes[chain[level]].lo, nodes[chain[level]].hi);
  // A parent orders its children by need: a changed need reorders the grandparent's children.
  while (structural && level > 0 && nodes_[chain[level]].need != nodes[chain[level]].need) {
    --level;
    region.grow(nodes_[chain[level]].lo, nodes_[chain[level]].hi);
    region.grow(nodes[chain[level]].lo, nodes[chain[level]].hi);
  }
  program_ = std::move(program);
  nodes_ = std::move(nodes);
  return region;
}

}  // namespace blobvk::blobtree
