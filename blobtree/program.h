// The compiled BlobTree: a flat post-order instruction list over a small register file, plus the
// primitive, matrix, box and warp records it refers to. This is the contract between the model
// and every evaluator (scalar reference, AVX, GLSL); see shaders/program_layout.h for the bytes.
#pragma once

#include "blobvk/shaders/program_layout.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace blobvk::blobtree {

struct Node;

static_assert(sizeof(layout::Instruction) == 16);
static_assert(sizeof(layout::PrimitiveRecord) == 64);
static_assert(sizeof(layout::MatrixRecord) == 48);
static_assert(sizeof(layout::BoxRecord) == 32);
static_assert(sizeof(layout::WarpRecord) == 32);
static_assert(offsetof(layout::PrimitiveRecord, meta) == 48);
static_assert(offsetof(layout::BoxRecord, hi) == 16);
static_assert(offsetof(layout::WarpRecord, params) == 16);

// Axis-aligned box in world space; empty when lo > hi on any axis.
struct Aabb {
  glm::vec3 lo{1e30f};
  glm::vec3 hi{-1e30f};
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  bool finite() const;  // non-empty and every bound below 1e29 in magnitude
  void grow(const glm::vec3& p);
  void grow(const Aabb& b);
};

struct Program {
  std::vector<layout::Instruction> code;
  std::vector<layout::PrimitiveRecord> primitives;
  std::vector<layout::MatrixRecord> matrices;  // [0] is the identity
  std::vector<layout::BoxRecord> boxes;
  std::vector<layout::WarpRecord> warps;
  // Host only (not uploaded): per primitive, a box outside which its field is exactly 0, in the
  // space of the point register it reads. Code generators use it to drop primitives from code
  // that only runs elsewhere (vk/eval/program_codegen.h); empty when unknown.
  std::vector<layout::BoxRecord> primitiveBoxes;
  std::uint32_t fieldRegisters = 0;  // registers the code uses (<= MAX_FIELD_REGISTERS)
  std::uint32_t pointRegisters = 1;  // 1 + deepest warp nesting (<= MAX_POINT_REGISTERS)
  Aabb bounds;  // where the field can be non-zero; infinite when an unbounded warp is at the root

  std::size_t byteSize() const;  // bytes of all records, what a GPU upload needs
};

struct CompileOptions {
  bool boxSkips = true;  // emit OP_SKIP for subtrees with a finite box (off: for comparisons)
  std::uint32_t minSkipPrimitives = 2;  // smallest subtree (in primitives) worth a skip test
};

// Folds transforms into per-primitive inverse matrices and emits the stackless code.
// Throws std::invalid_argument for trees it cannot compile (too deeply nested warps).
Program compile(const Node& root, const CompileOptions& options = {});

}  // namespace blobvk::blobtree
