// Edits as data: change one node of a BlobTree (transform, parameters, colour, add or remove a
// child), recompile, and say which region of world space may now have a different field or
// colour, so a polygonizer re-meshes only there (cpu_simd/incremental_polygonizer.h).
//
// The region is exact-by-construction, not a heuristic:
//  - Outside a node's box (compiled_nodes.h) its field is exactly 0, and every operator is
//    pointwise in its children. A node whose parameters, transform or colour change therefore
//    changes its ancestors' fields (and the blended colour) only inside its old and new boxes,
//    carried to world space through the enclosing warps.
//  - Adding or removing a child is not neutral (an absent child of an intersection is not a child
//    of field 0) and may reorder the parent's children by register need, i.e. change the float
//    summation order of a blend: the region is the parent's old and new boxes, and again the
//    grandparent's whenever the parent's need changed, and so on up.
// tests/blobtree/test_edit.cpp checks the region against the reference evaluator, bit for bit.
#pragma once

#include "blobvk/blobtree/compiled_nodes.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace blobvk::blobtree {

// Child indices from the root ({} is the root itself).
using NodePath = std::vector<std::size_t>;

struct SetTransform { Transform transform; };
struct SetPrimitive { Primitive primitive; };  // type, skeleton, support and colour
struct SetOperator { Operator op; };
struct SetWarp { Warp warp; };
// Kind (with its parameters), transform and id at once; the children stay. The kind must stay a
// primitive, an operator or a warp (to change that, remove the node and add another).
struct SetNode { Node node; };
struct AddChild {
  Node child;
  std::size_t at = std::size_t(-1);  // position among the children; past the end appends
};
struct RemoveChild { std::size_t at = 0; };

using Change = std::variant<SetTransform, SetPrimitive, SetOperator, SetWarp, SetNode, AddChild, RemoveChild>;

struct Edit {
  NodePath path;  // the node changed (Set*) or the parent (AddChild, RemoveChild)
  Change change;
};

// A box in world space: empty when nothing changed, +-1e30 bounds when everything may have.
struct Region {
  glm::dvec3 lo{1e30}, hi{-1e30};
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  bool everything() const;  // some bound is unbounded (a bend warp above the edit, say)
  void grow(const glm::dvec3& boxLo, const glm::dvec3& boxHi);
};

std::string toString(const NodePath& path);  // "[0, 3, 1]"

// A tree, its Program and the per-node bounds the next edit's region needs.
class EditableTree {
 public:
  // Throws std::invalid_argument when the tree does not compile.
  explicit EditableTree(Node root, const CompileOptions& options = {});

  const Node& root() const { return root_; }
  const Program& program() const { return program_; }

  // Applies the edit and recompiles the whole tree (docs/editing.md measures why that is
  // cheaper than patching records). Returns the region whose field or colour may differ.
  // Throws std::invalid_argument (a path that leads nowhere, a change that does not fit the
  // node, a tree that no longer compiles) and then leaves the tree and Program as they were.
  Region apply(const Edit& edit);

  // The node at a path; throws std::invalid_argument when the path leads nowhere.
  const Node& node(const NodePath& path) const;
  // The first node in pre-order with this id.
  std::optional<NodePath> find(std::string_view id) const;
  // The first `limit` nodes in pre-order with this id (scenes may repeat an id; an edit that
  // names a node by id needs it to name one).
  std::vector<NodePath> findAll(std::string_view id, std::size_t limit) const;

 private:
  Node root_;
  CompileOptions options_;
  Program program_;
  std::vector<CompiledNode> nodes_;  // per node in pre-order
};

}  // namespace blobvk::blobtree
