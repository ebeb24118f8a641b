// The specialised evaluator: a compiled Program turned into GLSL straight-line code (the
// Traversal::Specialised path). Each instruction of the stackless register code becomes a few
// statements with the records' values as literals, registers become local variables, and every
// OP_SKIP becomes a branch the whole subgroup takes when all its lanes are outside the box (or,
// on CPU drivers, code every lane runs, its result masked).
//
// Why: an interpreter pays, per instruction and lane, for loading the instruction and records and
// for selecting registers by index; llvmpipe (lavapipe) additionally runs both sides of every
// `if` and turns each storage-buffer load into a per-lane loop. Straight-line code leaves LLVM
// nothing to interpret. The formulas are those of shaders/eval_formulas.glsl, the same ones the
// interpreter calls, so results stay operation-for-operation those of blobtree/evaluate.cpp.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/program_shape.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace blobvk::vk {

struct MemoKey;

// The generator refuses code that would spell out more than this many instructions (after loops
// and pruning): beyond it glslang and LLVM take tens of seconds and gigabytes. Which evaluator
// pays within a job is the cost model's choice (vk/eval/evaluator_choice.h), not this cap.
inline constexpr std::size_t kMaxSpecialisedInstructions = 4096;

// A box of world-space points (inclusive). `valid` false: anywhere.
struct PointRegion {
  bool valid = false;
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
};

struct CodegenOptions {
  // true: each OP_SKIP becomes a loop the subgroup leaves when all its lanes are outside the box
  // (GPUs, where a uniform branch is cheap). false: the subtree always runs and outside lanes
  // get 0 afterwards — faster on llvmpipe, where loops and subgroup votes cost more than the
  // straight-line code they would skip (measured: tower 2x, random128 even; docs/vulkan.md).
  bool branchOnSkips = true;
  // With branchOnSkips, only subtrees of at least this many instructions get a branch; smaller
  // ones run masked (a branch costs more than a short subtree).
  std::uint32_t minBranchInstructions = 0;
  // The evaluator will only be called at points inside this region: every skip on the
  // world-space point whose box misses it becomes "field 0" with no code for its subtree — the
  // same result at those points, bit for bit (tape pruning at compile time; vk/eval/field_tiles.h).
  PointRegion region;
  // Runs of equal siblings (instances) become loops over one shared function
  // (vk/eval/program_shape.h); the instances' record values are read from the code buffer after the
  // instructions (specialisedData), so uploadProgram must be given the same options. Code in the
  // looped form branches on its skips (of at least minBranchInstructions) whatever branchOnSkips
  // says: masked, every lane would run every instance of every loop (the 3,024-instruction tower
  // at 64 cells: 88 s of field against 1 s branching).
  LoopOptions loops;
  // Unrolled code also defines the analytic gradient (vk/eval/gradient_codegen.h) for the vertex
  // kernels' normals; false: vertex kernels interpret it (shaders/eval_gradient.glsl), which
  // builds in a fraction of the time and memory and runs slower (the cost model weighs both).
  bool gradient = true;
};

// True when the skip box [lo, hi] holds no point of the region (a conservative test: false
// when the region is not valid).
bool regionMissesBox(const PointRegion& region, const layout::BoxRecord& box);

// Relative cost per point of the evaluator within `region` once pruned as above: a primitive or
// warp counts kPrimitiveCost, a pow (Ricci blend) kPowCost, any other instruction 1, what pruning
// removed 0 (a constant is left; a pruned primitive's or subtree's pow too). llvmpipe's pow is
// dear: a blend of 48 random points at 256 cells (one kernel, every row) takes 18 ns a point, and
// as a Ricci blend, 49 pows more, 282 ns (`blobvk bench S --backend vk --field-tiles 1
// --no-row-culling`, field_s per evaluated point): 5.4 ns a pow, 72 units of
// kSpecialisedSecondsPerCost (evaluator_costs.h).
inline constexpr std::uint32_t kPrimitiveCost = 8;
inline constexpr std::uint32_t kPowCost = 72;
std::uint32_t prunedEvaluationCost(const blobtree::Program& program, const PointRegion& region);

// A fingerprint of everything generateSpecialisedEvaluator's output depends on (the records, the
// register counts and the options): equal fingerprints mean equal code, so kernels can be looked
// up without generating their source again (2-3 ms for a 270-instruction program).
std::uint64_t evaluatorFingerprint(const blobtree::Program& program, const CodegenOptions& options);
// The same from programFingerprint(program), for callers generating many variants of one program.
std::uint64_t programFingerprint(const blobtree::Program& program);
std::uint64_t evaluatorFingerprint(std::uint64_t programFingerprint, const CodegenOptions& options);
// `loops` into a memo key (host_memo.h; field by field: the struct has padding).
MemoKey& addLoopOptions(MemoKey& key, const LoopOptions& loops);

// Instructions of the generated field code once pruned to `region` (what kMaxSpecialisedInstructions
// limits and what decides loops): a pruned subtree or primitive counts as one, and so does a run
// of children pruned out of one blend (spelled as one addition of 0).
std::uint32_t prunedInstructionCount(const blobtree::Program& program, const PointRegion& region);
// Instructions a point runs in `region` where the evaluator branches on skips (the interpreter,
// looped code): the program less the subtrees whose boxes the region misses.
std::uint32_t branchedInstructionCount(const blobtree::Program& program, const PointRegion& region);

// Instructions the generated code spells out for the program pruned to `region`, with loops as
// in `loops` (a shared function counts once): what compile time grows with.
std::uint32_t specialisedCodeSize(const blobtree::Program& program, const PointRegion& region = {},
                                  const LoopOptions& loops = {});

// True when the code generated for the program pruned to `region` takes the looped form (loops
// on, the code longer than loops.minProgramInstructions, and in the form compile() emits): it
// then branches on skips, reads record values from the code buffer, and its size is
// specialisedCodeSize, not the program's.
bool specialisedCodeLoops(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops);

// True when generateSpecialisedEvaluator accepts the program pruned to `region` (anywhere by
// default): a program too large as a whole can still be specialised for a small region.
bool canSpecialise(const blobtree::Program& program, const PointRegion& region = {}, const LoopOptions& loops = {});

// The record words the generated loops read, to be uploaded after the instructions in the code
// buffer (empty when the code has no loops).
std::vector<layout::uvec4> specialisedData(const blobtree::Program& program, const LoopOptions& loops);

// GLSL that replaces shaders/eval_program.glsl for this program: it defines
// evaluateField(vec3 p, uint n) and evaluateFieldColour(vec3 p, uint n, out vec3 colour) (n is
// ignored). It reads no Program buffer, except the code buffer's words after the instructions
// (specialisedData) when it has loops. Throws std::invalid_argument when !canSpecialise.
// `emitted` (optional) receives specialisedCodeSize.
std::string generateSpecialisedEvaluator(const blobtree::Program& program, const CodegenOptions& options = {},
                                         std::uint32_t* emitted = nullptr);

}  // namespace blobvk::vk
