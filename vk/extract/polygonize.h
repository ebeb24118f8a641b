// GPU marching cubes: the field in z-slab bricks, edge-crossing flags, two prefix sums (vertex
// and triangle offsets), vertices on crossing edges in global edge-key order (welded), and
// triangles in cell order then case-table order: the same mesh as cpu::polygonizeReference,
// index by index, wherever the two classify the grid points alike.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/eval/gpu_program.h"

#include <cstdint>
#include <functional>
#include <string>

namespace blobvk::vk {

// The sparse path's brick classification: which kernel runs the bound (vk/extract/classify_kernel.h).
enum class ClassifyCode {
  // The generated kernel where the device already holds it (an earlier job's), else the
  // interpreter; and where more runs are expected and the generated kernel pays for its build
  // over them (classifyCodePays), it builds in the background for the later jobs.
  Auto,
  Interpreter,  // always the interpreter
  Generated,    // the generated kernel wherever it can be (built now if need be): tests
};

struct GpuPolygonizeOptions {
  // Sparse extraction over bricks (vk/extract/sparse_polygonizer.h); false: the dense z-slab
  // pipeline of vk/extract/slab_polygonizer.h (also used with tiledVertexPass).
  bool sparse = true;
  // Cells per brick edge (sparse), a power of two from 2 to 16. 16 measured fastest on lavapipe
  // (docs/vulkan.md): 8 evaluates fewer points but classifies 8x as many bricks.
  std::uint32_t brickCells = 16;
  // Sparse: active bricks per batch (whole brick layers run together, one layer more than they
  // emit); 0: as many as fit one storage buffer and a quarter of the largest device-local heap.
  // The mesh is the same bytes whatever the batches.
  std::uint32_t maxBatchBricks = 0;
  // Several devices (multi_device.h), maxBatchBricks 0: batches per device (equal shares of the
  // active bricks, fewer where the memory limit cuts them smaller). Each batch evaluates one
  // brick layer more than it emits, so 1 suits equal devices; more let a faster device take more.
  std::uint32_t batchesPerDevice = 1;
  // Sparse: brick layers per window of the classification's tables (vk::ScanWindow); 0: as many
  // as one storage buffer holds (the whole grid but on the largest grids). The mesh is the same
  // bytes whatever the windows.
  std::uint32_t windowLayers = 0;
  // Sparse: every batch one brick layer whose triangles come back as corner keys, matched on the
  // host (what a layer pair over one storage buffer gets; sparse_batches.h), for tests. The same
  // bytes either way.
  bool keyedCornerBatches = false;
  bool normals = true;
  bool colours = true;
  int refineSteps = 0;         // regula-falsi steps after the linear interpolation
  float normalStep = 1e-4f;    // central-difference step (blobtree::normal's default)
  Traversal traversal = Traversal::Auto;  // Auto: the cost model's choice (vk/eval/evaluator_choice.h)
  // Auto: runs of this job with the same kernels the caller expects (a benchmark's repeats): the
  // cost model weighs the kernels' build once against this many runs (EvaluatorJob::repeats).
  std::uint32_t expectedRuns = 1;
  // Traversal::Specialised: code generation options (default: chosen for the device).
  const CodegenOptions* codegen = nullptr;
  std::uint32_t workgroupSize = 64;
  std::uint64_t maxBrickBytes = 32ull << 20;  // per-slab field bytes; smaller means more slabs
  // Traversal::Specialised: the field pass's tiles with pruned kernels (vk/eval/field_tiles.h); 1 = off.
  std::uint32_t maxFieldTiles = 8;
  // Sparse path, Traversal::Auto, expectedRuns > 1: the most field tiles a job that runs again may
  // take, where the cost model says the kernels past maxFieldTiles save more over the runs than
  // their builds cost (tower at 512 cells: 16 tiles, a quarter less field pass). At most
  // maxFieldTiles when it is not above it.
  std::uint32_t repeatedJobFieldTiles = 16;
  // Sparse path, Traversal::Auto, CPU drivers: field tiles whose pruned code would still loop (a
  // program of more than kLoopedAboveInstructionsOnCpu instructions) split on until it unrolls,
  // up to this many tiles in all (FieldTilingOptions::maxTilesForLoopedCode), where the cost model
  // says the unrolled kernels' builds pay (tower_L6P8I4 at 256 cells: 48 tiles, field pass 5-7 s
  // -> 0.2-0.25 s a run). A forced evaluator takes the tiles maxFieldTiles gives.
  std::uint32_t maxFieldTilesForLoopedCode = 128;
  // Dense path only. With field tiles, run the vertex pass per tile too, with the evaluator pruned to each tile.
  // Off by default: a vertex kernel inlines the evaluator 8 times and takes 0.1-0.16 s to build
  // on lavapipe (a field tile kernel ~0.035 s), while it saves ~30 % of the emit pass (tower at
  // 128 cells: 57 -> 40 ms) — worth it only when a polygonizer is used many times (an engine
  // re-extracting every frame), not for one mesh.
  bool tiledVertexPass = false;
  // Sparse path, specialised code with the generated gradient and field tiles: the vertex pass
  // per field tile too, each tile's vertices run by a vertex kernel pruned to its box of bricks
  // (docs/vulkan.md, "Sparse extraction"); the same mesh byte for byte. The pass takes 0.6-0.7 of
  // the time for 0.8-2 s of builds on lavapipe (its NIR work per kernel is not cached; tower and
  // random128 at 256 and 512 cells, docs/performance.md). Off, a job with expectedRuns > 1 still
  // takes them once they are built, and starts their build in the background when it is done,
  // so that no job waits for them: where that build is predicted to take at most
  // unbiddenBuildSeconds, or where the expected runs after the job repay it (evaluator_costs.h,
  // kTiledVertexSavingGenerated).
  bool sparseVertexTiles = false;
  double unbiddenBuildSeconds = 10.0;
  // Sparse path, specialised code (set by the cost model for Auto, EvaluatorEstimate::
  // interpretVertexPassUntilBuilt): while the generated-gradient vertex kernel is not built, the
  // vertex pass runs the embedded interpreter (the same bytes) instead of waiting for the build;
  // with expectedRuns > 1 the kernel builds in the background (Device::buildInBackground).
  bool interpretVertexPassUntilBuilt = false;
  // Sparse: the classification's kernel; every choice gives the same flags.
  ClassifyCode classifyCode = ClassifyCode::Auto;
  // Sparse path on llvmpipe (which reads the active-brick list back anyway): a host bound that
  // classifies the segments along x of a brick's columns, as cpu::ColumnSides does (its
  // arguments; sides 0 below the iso-value over a segment's closed box, 1 at or above it, 2
  // either), so that the field pass evaluates only the points of each row from its first segment
  // that may cross to its last; the others get their inside bits and no sample, since no vertex
  // reads one (vk/extract/row_culling.h). The same mesh byte
  // for byte, provided the bound is the job's program's and holds for the device's values
  // (cpu::ColumnSides::boundsHoldOnIeeeDevices). Called from several threads at once. Empty (the
  // library's default): every row of an active brick is evaluated. blobvk's CLI passes the CPU
  // backend's bound. IncrementalExtractor, whose edits change the program, ignores it.
  std::function<void(const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                     std::uint8_t* sides)>
      columnSides;
  // Sparse path on a CPU device (lavapipe) whose buffers the host maps cached: the bookkeeping
  // runs on the host in the mapped buffers, where as compute passes every load and store is a
  // loop over the lanes: the classification where `columnSides` is given (host_classify.h), and
  // per batch the row counts, the exclusive scans of them, the point words and sources, the
  // tiles' vertex lists and the triangles (host_row_passes.h, host_scan.h, vertex_tile_lists.h,
  // host_triangles.h); the device runs the field and vertex passes. The same bytes either way;
  // false: the device's passes, as on GPUs (CLI `--device-passes`).
  bool hostPassesOnCpuDevices = true;
  // Sparse: the field pass interprets, per brick, the program pruned to the brick on the host
  // (vk/extract/brick_tapes.h) instead of the traversal's field kernel or field tiles; the vertex
  // pass, where it would interpret the gradient, interprets each vertex's brick's vertex tape.
  // The same mesh byte for byte.
  bool brickTapes = false;
  // Sparse, without brickTapes: a vertex pass that would run the whole program's looped code
  // (a long program on a CPU driver) interprets each vertex's brick's vertex tape instead (the
  // same mesh). Auto sets it where the bricks' tapes are a small part of what looped code runs
  // (flat blends of hundreds of points; not towers, whose skips the looped code takes).
  bool vertexTapes = false;
  // With brickTapes: the tapes and the records they use in uniform blocks by windows of bricks
  // where the device's uniform range allows (vk/extract/brick_tapes.h); false: in one storage
  // buffer beside the program's records (what a batch whose tape is over a block falls back to).
  // The vertex tapes too, on a CPU device (a dispatch per window over the host's vertex lists).
  bool brickTapeUniforms = true;
  // Sparse: a vertex kernel that interprets the gradient without samples (no refinement; a first
  // job before the generated gradient is built, or the interpreter's traversal) reads the program
  // from uniform blocks where it fits them (vk/eval/uniform_program.h); false: from its storage
  // buffers. The same mesh.
  bool uniformVertexProgram = true;
  // Sparse: one line of text before each phase that can take minutes on a large grid (the
  // classification, its rerun with smaller bricks, the batches), on the calling thread; empty:
  // none. The CLI prints it as a progress note.
  std::function<void(const std::string&)> phaseNote;
  // Sparse: (done, total) after each window of brick layers the classification has finished, on
  // the calling thread, when it takes more than one (the largest grids, where it takes minutes);
  // a rerun with smaller bricks counts again from 1. Empty: none.
  std::function<void(std::size_t done, std::size_t total)> classifyProgress;
};

// Sparse: where the host's wall time goes, on the calling thread (`blobvk bench --json`:
// vk_phases.host_steps). The submits' figures hold the device's work and the host's wait for it;
// on a discrete GPU the mesh arrays grow during the second submit, so `grow` is inside `emitSubmits`.
struct HostSteps {
  double classification = 0.0;  // the bricks classified and compacted: host setup, submits, read-backs
  double preparation = 0.0;     // evaluator choice, batch plan, the batch runner (kernels, buffers)
  double fieldSubmits = 0.0;    // per batch: field to scans, recorded, submitted, waited for, counts read
  double emitSubmits = 0.0;     // per batch: output buffers, sources to the read-back copy, waited for
  double grow = 0.0;            // the mesh arrays grown for each batch's outputs
  double copy = 0.0;            // each batch's outputs copied into the mesh arrays (with a read-back
                                // copy, all but the last output's during emitSubmits)
  double corners = 0.0;         // keyed-corner batches: triangle corners found by edge key
  double rowCulling = 0.0;      // per batch (GpuPolygonizeOptions::columnSides): rows bounded and listed, uploaded
  double scans = 0.0;           // per batch, CPU devices: the segment scans on the host (host_scan.h; inside fieldSubmits)
  double vertexTileLists = 0.0; // per batch, CPU devices, vertex tiles: the tiles' lists on the host (inside emitSubmits)
  double rows = 0.0;            // per batch, CPU devices: each row's counts on the host (host_row_passes.h; inside fieldSubmits)
  double sources = 0.0;         // per batch, CPU devices: point words and sources on the host (host_row_passes.h; inside emitSubmits)
  double triangles = 0.0;       // per batch, CPU devices: the triangles assembled on the host (host_triangles.h)
};

struct GpuStats {
  double seconds = 0.0;          // wall time of all submits and readbacks
  // Dense: field, flags, cell counts, scans. Sparse: the bricks' classification and compaction.
  double classifySeconds = 0.0;
  double emitSeconds = 0.0;      // dense: vertices (with normals/colours), triangles, read-back
  double fieldSeconds = 0.0;     // sparse: the field at the active bricks' points
  double extractSeconds = 0.0;   // sparse: edges, counts, scans, vertices, triangles
  double readbackSeconds = 0.0;  // sparse: the mesh copied to the host (device copy + host copy)
  double readbackDeviceSeconds = 0.0;  // ... of which the device's copy into read-back memory (device time)
  // Sparse, device time only: extractSeconds by pass.
  double edgesSeconds = 0.0;      // inside masks, crossing edges, per-row counts
  double scansSeconds = 0.0;      // the segment scans
  double sourcesSeconds = 0.0;    // per row: where each vertex and triangle comes from
  double verticesSeconds = 0.0;   // positions, normals, colours, edge keys
  double trianglesSeconds = 0.0;  // triangle indices
  // Sparse: with timestamps on the queue (deviceTimed), classify/field/extract are device time
  // and hostSeconds is the rest of `seconds` (submits, waits, allocations, host copies); without,
  // they are wall time per submit (the field counted in extract).
  bool deviceTimed = false;
  double hostSeconds = 0.0;
  HostSteps hostSteps;
  std::uint32_t submits = 0;     // sparse: queue submissions (each one a host round trip)
  std::uint32_t batches = 0;     // sparse: batches of brick layers (1 + 2 x batches submits; 3 for a
                                 // batch whose device writes the sources and host lists the vertex tiles)
  std::uint32_t devices = 1;     // devices that shared the batches (multi_device.h)
  std::uint32_t bricks = 0;      // dense: z-slabs; sparse: bricks of the grid
  std::uint32_t activeBricks = 0;  // sparse: bricks that may hold surface
  std::uint32_t brickCells = 0;    // sparse: cells per brick edge
  std::uint64_t deviceBytes = 0;   // sparse: device memory of the extraction's buffers
  std::uint32_t fieldTiles = 0;        // field and vertex passes run per tile (vk/eval/field_tiles.h)
  std::uint32_t vertexTiles = 0;       // sparse: vertex kernels pruned per field tile (0: one kernel)
  std::uint64_t tapeInstructions = 0;  // sparse, brick tapes: sum of the bricks' tape lengths
  std::uint64_t tapeWords = 0;         // ... instructions stored (equal tapes once)
  double tapeSeconds = 0.0;            // ... host time building them
  std::uint64_t tapeBytes = 0;         // ... device bytes of their buffers (in deviceBytes)
  std::uint64_t fieldEvaluations = 0;  // grid samples (per vertex add evaluationsPerVertex)
  // Sparse: the evaluator the batches ran, and on CPU drivers what the cost model
  // (vk/eval/evaluator_choice.h) predicted for it (seconds; < 0 where it made no prediction).
  Traversal traversal = Traversal::Auto;
  bool vertexGradient = false;  // false too where the vertex pass interpreted while it built
  bool vertexUniforms = false;  // sparse: the interpreted gradient read the program from uniform blocks
  bool vertexTapes = false;     // sparse: ... each vertex's brick's tape (with the field's brick tapes)
  std::uint32_t vertexTapeWindows = 0;  // sparse: ... from uniform blocks, in this many windows (all batches)
  bool hostClassification = false;  // sparse: the bricks classified on the host (host_classify.h)
  bool generatedClassification = false;  // sparse: the bricks classified by generated code (classify_kernel.h)
  std::uint32_t classifyTiles = 0;  // sparse: tiles the interpreted classification ran, each with its tape (0: whole program)
  double modelBuildSeconds = -1.0, modelRunSeconds = -1.0;
};

mesh::TriMesh polygonize(Device& device, const blobtree::Program& program,
                         const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options = {},
                         GpuStats* stats = nullptr);

// polygonize into `mesh`'s arrays: cleared, their capacity kept. A host that meshes again (an
// engine re-meshing each frame, `blobvk bench`'s repeats) then pays no allocation and no page
// faults for a mesh no larger than its last one: on a discrete GPU the mesh's fresh pages cost
// more than the device's work. The same bytes as polygonize.
void polygonizeInto(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                    const GpuPolygonizeOptions& options, mesh::TriMesh& mesh, GpuStats* stats = nullptr);

// Field evaluations each output vertex costs past the grid's samples (GpuStats::fieldEvaluations),
// counted as the CPU backend counts its own (cpu::MpuStats): `options.refineSteps` refinement
// samples, at most (a sample exactly on the iso-value ends its vertex's steps early; the device
// does not count those), and the attribute pass: one analytic-gradient pass for normal and
// colour, or, for the stack-based traversal (`ran`: GpuStats::traversal), six central-difference
// samples for the normal and one colour pass.
std::uint32_t evaluationsPerVertex(const GpuPolygonizeOptions& options, Traversal ran);

}  // namespace blobvk::vk
