// What compile() knows about each node of a tree that an edit needs (edit.h): where the node's
// field can be non-zero, in world space, and how many registers its code needs (a change of
// which reorders its parent's children, i.e. the float summation order of a blend).
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace blobvk::blobtree {

struct CompiledNode {
  // Outside [lo, hi] (world space) the node's field is exactly 0: its box as compile() bounds
  // it for OP_SKIP (full kernel support), carried out through the enclosing warps as a warp
  // carries its child's box. Unbounded: +-1e30. Empty: lo > hi.
  glm::dvec3 lo{1e30}, hi{-1e30};
  std::uint32_t need = 1;         // field registers (Sethi-Ullman number)
  std::uint32_t subtreeSize = 1;  // nodes in the subtree, itself included
};

// compile(), also filling `nodes` with one entry per tree node in pre-order (a node, then its
// children's subtrees in order): node i's children start at i + 1.
Program compile(const Node& root, const CompileOptions& options, std::vector<CompiledNode>& nodes);

}  // namespace blobvk::blobtree
