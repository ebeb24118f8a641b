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

#include <cstddef>
#include <cstdint>

namespace blobvk::vk::costs {

// Building is single-threaded LLVM work: wall seconds of a quiet 2-core machine, from the CPU
// seconds of fresh processes meshing a scene at 8 cells (where evaluation costs nothing), each
// evaluator forced, fastest of three (`python`-free form: `/usr/bin/time -f '%U %S' blobvk
// --pipeline-cache off mesh S -o m.ply --resolution 8 --backend vk --traversal T -q`). What the
// specialised kernels of a mesh (field, and vertices with the generated gradient) cost beyond the
// interpreter's: eggshell (4 instructions) +0.01-0.04 s, twisted_column (25) +0.10, craniotomy
// (28) +0.07, creature and dice (48) +0.21 and +0.23, tower L1P8G1 (67) +0.28, L2P8G1 (134)
// +0.72, tower (268) +1.28, random128 (256) +2.15.

// Building one kernel that embeds the interpreter (field_grid or vertices): its SPIR-V is
// embedded, so this is pipeline creation and LLVM, independent of the program. A stackless mesh
// at 8 cells takes 0.21-0.31 s of CPU in all, the device's start and the fixed extraction kernels
// included, so each interpreter kernel is a small part of it.
inline constexpr double kInterpreterKernelSeconds = 0.03;

// Building one specialised kernel: a fixed part (glslang on generated source, then as the
// interpreter's), then per instruction the generated evaluator spells out times the copies of
// the evaluator in the kernel (field_grid 1; vertices 2.5 with the interpreted gradient: one field
// call site for the refinement and normal samples, shaders/edge_vertex.glsl, and the colour
// evaluator, about 1.5 field copies with its colour registers; 4 with the generated gradient),
// and a quadratic term: LLVM's time on long straight-line code grows faster than the code.
// Fitted to the differences above (48 and 134 instructions exactly, the others within 0.05 s
// below 100 instructions; tower and random128 at 268/256 bracket the 1.9 s it predicts).
inline constexpr double kSpecialisedKernelSeconds = 0.04;
inline constexpr double kSpecialisedSecondsPerInstruction = 7.2e-4;
inline constexpr double kSpecialisedSecondsPerInstruction2 = 7.3e-7;
// The vertex kernel with the interpreted gradient builds like 1.5 field copies (tower L2P8G1 at 8
// cells: +0.29 s over the interpreter with it, +0.72 s with the generated gradient).
inline constexpr double kVertexKernelCopies = 1.5;
// Its build's memory still grows like 2.5 field copies (the bound below keeps its earlier fit).
inline constexpr double kVertexKernelMemoryCopies = 2.5;
// With the generated gradient (vk/eval/gradient_codegen.h) the vertex kernel holds the field code
// and the gradient's, which spells out field, gradient and colour per instruction: its build
// grows like 4 field copies, its memory like 6.5 (`blobvk --pipeline-cache off mesh S
// --resolution 64 --backend vk --traversal specialised` against the interpreted gradient, peak
// RSS: L2P8G1 +80 MB, L3P8G1 +128 MB, tower +177 MB, random128 +220 MB).
// (Fitted while the generated kernels still carried their uncalled functions and the gradient a
// switch over every primitive type at each primitive; tower's vertex kernel now creates in about
// a fifth less time, so this over-estimates, on the side of the interpreted gradient.)
inline constexpr double kGradientVertexKernelCopies = 4.0;
inline constexpr double kGradientVertexKernelMemoryCopies = 6.5;
// The interpreted gradient at a vertex costs about this many interpreter evaluations of the field
// (vec3 gradient and colour registers selected by index) per vertex of the model's estimate
// (kVerticesPerSurfacePoint): the extraction of random128 at 256 cells took 17.9 s interpreting it
// and 1.6 s generated (1.6 evaluations), tower 2.7 s and 1.0 s (2.1)
// (`blobvk bench S --resolution 256 --backend vk`, `vk_phases`).
inline constexpr double kInterpretedGradientEvaluations = 2.0;
// Without refinement, a program that fits uniform blocks (vk/eval/uniform_program.h) has its
// gradient interpreted from them (brick_vertices_direct_uniform) in this fraction of the
// estimate above (which also over-counts the vertices before they are known): first jobs'
// interpreted vertex passes against the model's storage-buffer estimate, tower on its own grid
// 0.043 s against 0.29 s, random128 at 256 cells 1.23 s against 8.7 s, dice 0.32 s against
// 4.2 s, creature 0.13 s against 1.8 s (0.07-0.15; the largest taken). From storage buffers
// tower's pass took 0.12-0.135 s. (`blobvk bench S --backend vk --repeats 1 --json`, warm
// caches, `vk_phases.extraction_passes_s.vertices`, the interpreted pass forced.)
inline constexpr double kUniformInterpretedGradientFraction = 0.15;
// The sparse path's brick classification (vk/extract/classify_kernel.h), per step of
// classifyWork (an instruction run by a vector of 8 lanes): the interpreter's seconds (random128
// at 512 cells: 1.2 M steps, 0.17-0.18 s), the generated code's cost relative to it (measured
// 0.11-0.79 on the shipped scenes but tower; the least gain, random128's 0.63-0.79, comes from
// its one primitive type and its alternating primitives and sums, which make the interpreter's
// steps cheap), and the margin it must beat the interpreter by. Each skip costs the generated
// code far more than a step: tower (69 skips, its walk predicting as many steps either way)
// classifies 1.6-1.8x slower generated (every branch is a loop llvmpipe leaves by a vote, and
// the registers written in it go through memory), while programs of up to 5 skips gain 1.3-9x;
// a program with more than kClassifyGeneratedMaxSkips stays interpreted
// (`bench_vk --benchmark_filter=classify/`, docs/performance.md).
inline constexpr double kClassifyInterpretedSecondsPerStep = 1.5e-7;
inline constexpr double kClassifyGeneratedStepCost = 0.6;
inline constexpr double kClassifyGeneratedMargin = 0.8;
inline constexpr std::size_t kClassifyGeneratedMaxSkips = 16;
// The interpreter classifying tile by tile (vk/extract/classify_tiles.h): each dispatch (one per
// tile and level) costs about this much beyond its steps (small boxes fill few of a dispatch's
// 4 x 4 x 4 work groups), and the tiles are taken where they are predicted to finish within this
// fraction of the whole program's steps.
inline constexpr double kClassifyTileDispatchSeconds = 5e-5;
inline constexpr double kClassifyTilesMargin = 0.7;
// Its build, far slower per instruction than a field kernel's (each instruction an interval bound
// of boxes, in blocks of vk/eval/interval_codegen.h's loops): CPU seconds of a fresh process,
// caches off, less the interpreter's (`MESA_SHADER_CACHE_DISABLE=true XDG_CACHE_HOME=<empty>
// /usr/bin/time bench_vk --benchmark_filter=classify/generated/S/512 --benchmark_min_time=0.001`
// against classify/interpreter/S): dice (48 instructions) 0.4-1.2 s, random128 (256) 8.3 s.
inline constexpr double kClassifyBuildSecondsPerInstruction = 2.8e-3;
inline constexpr double kClassifyBuildSecondsPerInstruction2 = 1.16e-4;
// Peak memory of the build grows about linearly (808 instructions x 10 copies: +570 MB); a
// candidate predicted above kMaxBuildMegabytes is not taken whatever its time.
inline constexpr double kBuildMegabytesPerInstruction = 0.15;
inline constexpr double kMaxBuildMegabytes = 300.0;

// Evaluating. The unrolled code on llvmpipe runs every line (no real branches, skips masked), so
// it pays for the code in the kernel: seconds per point and unit of prunedEvaluationCost (a
// primitive 8, an operator 1), from field evaluations on 129^3 grids (bench_vk
// --benchmark_filter='field/.*/128'): tower 10.9 M/s specialised (8 tiles).
// Run constants are quiet-machine wall seconds with LP_NUM_THREADS=2, as the build constants.
inline constexpr double kSpecialisedSecondsPerCost = 0.75e-10;
// The interpreter's subgroups jump over skipped subtrees, so it pays per instruction run
// (evaluator_choice.cpp's branchingWork, vertex evaluations at the mean). Fitted to whole meshes
// at 64 cells, `blobvk bench S --backend vk --traversal stackless --resolution 64 --repeats 2`
// steady seconds against the model's instructions, on a machine loaded about twice over: tower
// 5.5e-8, tower L5P8G3 3.3e-8, L3P8G2 7.2e-8, dice and random128 1.5e-7 (their primitives
// overlap, so subgroups skip less); halved for a quiet machine (quiet whole meshes at 64 cells:
// random128's interpreted evaluation about 4.5 s, dice's 0.9 s).
inline constexpr double kInterpreterSecondsPerInstruction = 3.0e-8;

// Looped code (vk/eval/program_shape.h) on llvmpipe: every load of an instance's record values
// is a loop over the lanes, so a kernel builds like the interpreter's (a fixed part beyond its
// few spelled-out instructions), and it branches on skips as the interpreter does, in 0.47-0.72
// of its time (tower L5P8G3 and tower_L6P8I4 meshed at 64 cells, the same command with
// --traversal specialised and looped code).
// Its kernels build in the interpreter's time plus the few spelled-out instructions' (at 8
// cells, as above: the two looped mesh kernels of towers L3P8G2, L5P8G3 and tower_L6P8I4 cost
// 0.05-0.16 s beyond the interpreter's).
inline constexpr double kLoopedKernelSeconds = kInterpreterKernelSeconds;

// Unrolled specialised code is taken only where the model predicts it finishes within this
// fraction of the interpreter's time. Its build is predicted to within ~0.05 s below 150 instructions, but
// the interpreter's run per instruction varies about 4x between scenes (how often its subgroups
// skip together), and the interpreter is the evaluator the default must never lose to: on a
// quiet machine creature at 64 cells meshes in 0.38 s interpreted against 0.42 s specialised,
// where the model without this margin predicted the reverse.
inline constexpr double kSpecialisedPaybackFraction = 0.7;
inline constexpr double kLoopedSecondsPerInstruction = 0.6 * kInterpreterSecondsPerInstruction;
// Looped code pruned to a field tile runs about this share of the tile's instructions at a point
// (its skips leave the rest): tower_L6P8I4 at 256 cells on lavapipe, 16 looped tiles of 400-600
// instructions, field 0.75 us a point, about 40 instructions at kLoopedSecondsPerInstruction.
inline constexpr double kLoopedTileRunShare = 0.08;
// The field pass over per-brick tapes (vk/extract/brick_tapes.h, interpreted from uniform
// blocks): seconds per tape instruction and point, the tapes' lengths summed over the active
// bricks (`bench S --backend vk --brick-tapes --json`: field_s over tape_instructions and the
// bricks' points; flat blends of 300 and 600 points 11.5-12.3 ns, towers L3P8G2 and tower_L6P8I4
// 7.3-8.2 ns, whose skips jump part of their tapes).
inline constexpr double kTapeSecondsPerInstruction = 1.2e-8;
// On CPU drivers code longer than this is generated looped (LoopOptions::minProgramInstructions,
// defaultCodegenOptions). Below it the unrolled mesh kernels build in under ~4 s and then run
// 10-50x faster than the interpreter; above it their build grows quadratically (808
// instructions: ~18 s) while looped code builds in under a second at any size.
inline constexpr std::uint32_t kLoopedAboveInstructionsOnCpu = 400;

// The tiles' vertex kernels that a job expected to run again builds after it, in the background
// (vk/extract/sparse_batches.cpp). A build predicted (specialisedKernelSeconds, the generated
// gradient's copies) within GpuPolygonizeOptions::unbiddenBuildSeconds (10 s) starts unbidden:
// the shipped scenes' 2-5 s (tower, random128 at 256 and 512 cells) repay themselves in tens of
// runs, which is what an engine re-meshing a scene wants. A longer one starts only where the
// caller's expected runs after the job repay it, each saving this share of the job's measured
// vertex pass: 0.3 where that pass ran the whole program's generated code (tower and random128 at
// 512 cells: 67 -> 45 and 210 -> 130 ms), 0.75 where it interpreted the gradient or ran vertex
// tapes (at 256 cells: tower_L6P8I4 0.67 s over vertex tapes in uniform blocks, 3.4 s looped,
// 0.18 s tiled; a random blend of 1024 points 1.8 s over the tapes, 0.54 s tiled). The
// prediction is within 3x of these long builds (`bench S --resolution 256 --backend vk`,
// background_build_wait_s): tower_L6P8I4 98 s predicted, 31-37 s measured; a random blend of
// 2048 points 92 s predicted, 136 s measured.
inline constexpr double kTiledVertexSavingGenerated = 0.3;
inline constexpr double kTiledVertexSavingInterpreted = 0.75;

// Vertex pass: vertices ~ this many per grid point^(2/3) (a surface's cells) when the active
// bricks are not known, each evaluated 8 times plus the refinement steps.
inline constexpr double kVerticesPerSurfacePoint = 10.0;
// With the active bricks known: vertices ~ this many per active brick and cell of a brick face
// (16^2 cells): shipped scenes at 64 cells range 0.23 (creature) to 3.0 (tower_L6P8I4), median
// 1.5 (`blobvk bench S --resolution 64 --backend vk --json`: vertices / vk_phases.active_bricks).
inline constexpr double kVerticesPerBrickFaceCell = 1.5;
inline constexpr double kEvaluationsPerVertex = 8.0;

}  // namespace blobvk::vk::costs
