// Measured costs of the evaluators on lavapipe (Mesa 22.3 llvmpipe, LLVM 15, LP_NUM_THREADS=2,
// this project's 2-core Debian 12 machine), the constants of vk/eval/evaluator_choice.cpp's model.
// Re-measure after changing the shaders or the code generator:
//
//   LP_NUM_THREADS=2 MESA_SHADER_CACHE_DISABLE=true build/release/bench/bench_compile_cost
//       --benchmark_counters_tabular=true
//
// Compile times include what llvmpipe does at a pipeline's first dispatch (NIR -> LLVM ->
// machine code): lavapipe builds the LLVM variant there, not in vkCreateComputePipelines.
#pragma once

#include <cstdint>

namespace blobvk::vk::costs {

// Figures are wall seconds with other builds running on the machine (load average 6-9), so
// about 2x a quiet machine's; only their ratios decide.

// Building one kernel that embeds the interpreter (field_grid or vertices): SPIR-V is embedded,
// so this is pipeline creation and LLVM, independent of the program. (A mesh's kernels: 3.7-4.9 s
// for the interpreter, of which ~1.9 s the fixed extraction kernels every evaluator builds.)
// Refitted: `blobvk bench scenes/tower.json --backend vk --traversal stackless --resolution 64
// --repeats 2` starts up (first run minus steady) in 0.7-1.1 s for all of a mesh's kernels, the
// fixed extraction kernels included.
inline constexpr double kInterpreterKernelSeconds = 0.3;

// Building one specialised kernel: a fixed part, then per instruction the generated evaluator
// spells out times the copies of the evaluator in the kernel (field_grid 1; vertices 2.5: one
// field call site for the refinement and normal samples, shaders/edge_vertex.glsl, and the
// colour evaluator, about 1.5 field copies with its colour registers), and a quadratic term: LLVM's time
// on long straight-line code grows much faster than the code. Unrolled towers, a mesh's kernels:
// 67 instructions 2.8 s, 201 4.9 s, 808 103 s and 734 MB. The quadratic term is fitted so that
// the shipped tower (268 instructions, a 2,412-instruction vertex kernel) builds in the ~1.5 s
// `blobvk bench scenes/tower.json --backend vk --traversal specialised --resolution 128` shows
// for its first run beyond the interpreter's; past ~470 instructions the memory bound below
// rules the vertex kernel out before this term matters.
inline constexpr double kSpecialisedKernelSeconds = 0.1;
inline constexpr double kSpecialisedSecondsPerInstruction = 1.0e-4;
// Refitted with one evaluator call site in the vertex kernel: the generated 808-instruction
// tower (L3P8G2, `blobvk generate tower --levels 3 --pillars 8 --grid 2`) meshed at 64 cells
// with its field kernel and a 2,020-instruction vertex kernel took 21.9 s and 423 MB against
// 1.8 s/107 MB for a small scene, so ~18 s and ~310 MB are its two kernels' build.
inline constexpr double kSpecialisedSecondsPerInstruction2 = 3.0e-6;
inline constexpr double kVertexKernelCopies = 2.5;
// With the generated gradient (vk/eval/gradient_codegen.h) the vertex kernel holds the field code
// and the gradient's, which spells out field, gradient and colour per instruction. Fitted to
// `blobvk --pipeline-cache off mesh S --resolution 64 --backend vk --traversal specialised`
// against the same with the interpreted gradient (user seconds, peak RSS): tower L2P8G1 (134
// instructions) +0.5 s and +80 MB, L3P8G1 (201) +0.6 s and +128 MB, tower (268) +1.2 s and +177
// MB, random128 (256) +1.6 s and +220 MB: the build's memory grows like 6.5 field copies, its time
// (in this file's loaded-machine seconds, about twice those user seconds) like 4.
inline constexpr double kGradientVertexKernelCopies = 4.0;
inline constexpr double kGradientVertexKernelMemoryCopies = 6.5;
// The interpreted gradient at a vertex costs about this many interpreter evaluations of the field
// (vec3 gradient and colour registers selected by index) per vertex of the model's estimate
// (kVerticesPerSurfacePoint): the extraction of random128 at 256 cells took 17.9 s interpreting it
// and 1.6 s generated (1.6 evaluations), tower 2.7 s and 1.0 s (2.1)
// (`blobvk bench S --resolution 256 --backend vk`, `vk_phases`).
inline constexpr double kInterpretedGradientEvaluations = 2.0;
// Peak memory of the build grows about linearly (808 instructions x 10 copies: +570 MB); a
// candidate predicted above kMaxBuildMegabytes is not taken whatever its time.
inline constexpr double kBuildMegabytesPerInstruction = 0.15;
inline constexpr double kMaxBuildMegabytes = 300.0;

// Evaluating. The unrolled code on llvmpipe runs every line (no real branches, skips masked), so
// it pays for the code in the kernel: seconds per point and unit of prunedEvaluationCost (a
// primitive 8, an operator 1), from field evaluations on 129^3 grids (bench_vk
// --benchmark_filter='field/.*/128'): tower 10.9 M/s specialised (8 tiles).
inline constexpr double kSpecialisedSecondsPerCost = 1.5e-10;
// The interpreter's subgroups jump over skipped subtrees, so it pays per instruction run
// (evaluator_choice.cpp's branchingWork, vertex evaluations at the mean). Fitted to whole meshes
// at 64 cells, `blobvk bench S --backend vk --traversal stackless --resolution 64 --repeats 2`
// steady seconds against the model's instructions: tower 5.5e-8, tower L5P8G3 3.3e-8, L3P8G2
// 7.2e-8, dice and random128 1.5e-7 (their primitives overlap, so subgroups skip less).
inline constexpr double kInterpreterSecondsPerInstruction = 6.0e-8;

// Looped code (vk/eval/program_shape.h) on llvmpipe: every load of an instance's record values
// is a loop over the lanes, so a kernel builds like the interpreter's (a fixed part beyond its
// few spelled-out instructions), and it branches on skips as the interpreter does, in 0.47-0.72
// of its time (tower L5P8G3 and tower_L6P8I4 meshed at 64 cells, the same command with
// --traversal specialised and looped code).
inline constexpr double kLoopedKernelSeconds = 0.3;
inline constexpr double kLoopedSecondsPerInstruction = 0.6 * kInterpreterSecondsPerInstruction;
// On CPU drivers code longer than this is generated looped (LoopOptions::minProgramInstructions,
// defaultCodegenOptions). Below it the unrolled mesh kernels build in under ~4 s and then run
// 10-50x faster than the interpreter; above it their build grows quadratically (808
// instructions: ~18 s) while looped code builds in under a second at any size.
inline constexpr std::uint32_t kLoopedAboveInstructionsOnCpu = 400;

// Vertex pass: vertices ~ this many per grid point^(2/3) (a surface's cells), each evaluated
// 8 times plus the refinement steps.
inline constexpr double kVerticesPerSurfacePoint = 10.0;
inline constexpr double kEvaluationsPerVertex = 8.0;

}  // namespace blobvk::vk::costs
