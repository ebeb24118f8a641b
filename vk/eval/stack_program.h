// The stack-based traversal's input: the Program's register code turned back into a tree and
// encoded as nodes that the shader walks with an explicit node stack and value stack, visiting
// each operator once per child as a recursive evaluator would. This is the thesis' stack-based
// kernel (Table 4.2) made complete; the stackless register code is what it is compared with.
//
// Two Instruction records per node: node n is code[2n] = (kind | opcode << 8, payload, point,
// 0) and code[2n + 1] = (first child, next sibling, 0, 0), ~0u for none. Node 0 is the root.
// Warps become nodes above each leaf or box that reads a warped point (a tree walk has no
// point registers to share), so the warped point is recomputed per leaf: part of what the
// register code saves.
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstdint>
#include <vector>

namespace blobvk::vk {

inline constexpr std::uint32_t TREE_LEAF = 1;   // payload primitive, point register
inline constexpr std::uint32_t TREE_OP = 2;     // opcode folds the children left to right
inline constexpr std::uint32_t TREE_UNARY = 3;  // OP_POW (payload exponent bits) / OP_ONE_MINUS
inline constexpr std::uint32_t TREE_BOX = 4;    // payload box, point register; one child
inline constexpr std::uint32_t TREE_WARP = 5;   // payload warp, point = dst | src << 8; one child
inline constexpr std::uint32_t kMaxTreeDepth = 48;  // the shader's stack size

// Throws std::invalid_argument when the tree is deeper than kMaxTreeDepth.
std::vector<layout::Instruction> buildStackProgram(const blobtree::Program& program);

}  // namespace blobvk::vk
