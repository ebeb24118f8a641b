// Sparse GPU marching cubes over bricks of B^3 cells (docs/vulkan.md, "Sparse extraction"):
//  1. brick_classify: a conservative interval of the field over each brick's grid points (the
//     CPU's early-discard bound, cpu_simd/field_bounds.cpp, run on the device); bricks whose
//     samples provably lie on one side of the iso value are dropped; large grids run coarser
//     levels (bricks of 2B, 4B, ...) first, and a brick whose parent was dropped is dropped;
//  2. an exclusive scan of the flags and brick_compact: the active bricks in (bz, by, bx) order;
//  3. brick_field: the field at the (B+1)^3 points of each active brick only, one lane per row
//     of points, and the row's inside bits packed in one word; brick_neighbours: each brick's
//     upper neighbours and where its rows go in the global order (one record per brick);
//  4. brick_rows: vertex counts per row of points (its owned crossing edges, from the inside
//     masks), triangle counts per row of cells, each at its position in the global order
//     (shaders/brick_layout.glsl), two scans; a lane per column of rows walking z;
//  5. brick_sources, per row: each point's word (first vertex, crossing edges), and where each
//     of its vertices and triangles comes from;
//  6. brick_vertices, one lane per vertex, and brick_triangles, one lane per four triangles; no search.
// Device memory follows the active bricks: besides 8 bytes per brick of the grid (in windows of
// brick layers where they outgrow one storage buffer, ScanWindow), each active
// brick holds two words per point of its (B+1)^3 (sample, point word), 2 per row of points, 1 per row of cells. The mesh equals
// cpu::polygonizeReference index by index (vertices in global edge-key order, triangles in cell
// order) wherever the two classify the grid points alike.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/classify_kernel.h"
#include "blobvk/vk/extract/polygonize.h"

#include <array>
#include <bit>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace blobvk::vk {

// Bricks per axis for `grid` with bricks of `brickCells` cells (a power of two, 2 .. 16).
struct BrickGrid {
  std::uint32_t log2B = 3;
  std::uint32_t x = 1, y = 1, z = 1;
  std::uint64_t count() const { return std::uint64_t(x) * y * z; }
  // Active-brick lists hold packed coordinates x | y << bitsX | z << (bitsX + bitsY), each axis in
  // the bits its brick count needs (shaders/brick_layout.glsl, packBrick, unpackBrick):
  // brickGridFor refuses a grid whose three widths exceed one word (and bx + by stays under 23).
  std::uint32_t bitsX() const { return std::uint32_t(std::bit_width(x - 1)); }
  std::uint32_t bitsY() const { return std::uint32_t(std::bit_width(y - 1)); }
  std::uint32_t bitsZ() const { return std::uint32_t(std::bit_width(z - 1)); }
  std::uint32_t pack(const std::array<std::uint32_t, 3>& b) const { return b[0] | b[1] << bitsX() | b[2] << (bitsX() + bitsY()); }
  std::array<std::uint32_t, 3> unpack(std::uint32_t p) const {
    const std::uint32_t bx = bitsX(), by = bitsY();
    return {p & ((1u << bx) - 1u), (p >> bx) & ((1u << by) - 1u), p >> (bx + by)};
  }
};
BrickGrid brickGridFor(const blobtree::GridSpec& grid, std::uint32_t brickCells);

// A box of bricks: [first, end) per axis (x, y, z).
struct BrickBox {
  std::array<std::uint32_t, 3> first{0, 0, 0}, end{0, 0, 0};
  bool empty() const { return end[0] <= first[0] || end[1] <= first[1] || end[2] <= first[2]; }
  std::uint64_t count() const {
    return empty() ? 0 : std::uint64_t(end[0] - first[0]) * (end[1] - first[1]) * (end[2] - first[2]);
  }
};
BrickBox wholeGrid(const BrickGrid& bricks);

// Device bytes the sparse path allocates for `activeBricks` active bricks producing `vertices`
// and `triangles` (the output buffers included), for --max-memory style estimates, plus
// `tapeBytes` where the field runs over per-brick tapes (GpuStats::tapeBytes: their size depends
// on the program pruned to each brick, known once the bricks are).
std::uint64_t sparseDeviceBytes(const BrickGrid& bricks, std::uint64_t activeBricks, std::uint64_t vertices,
                                std::uint64_t triangles, bool normals, bool colours, std::uint64_t tapeBytes = 0);

// The classification alone: 1 for each brick (x fastest) that may hold part of the surface, 0
// for one whose (B+1)^3 grid samples provably lie on one side of the iso value. The Program's
// records go in uniform buffers where they fit (64 KB per record array; brick_classify_uniform),
// else, or with `uniformRecords` false, in storage buffers (brick_classify): the same flags.
// `code`: the interpreter, or the kernel generated for the program (classify_kernel.h, uniform
// records only): the same flags. `forcedTiles` > 1: the interpreter tile by tile with pruned
// tapes (classify_tiles.h), at most that many, wherever the plan has several whether or not they
// pay (`tilesRun`: how many); its flags may drop more bricks than the whole program's, never one
// with surface.
std::vector<std::uint32_t> classifyBricks(Device& device, const blobtree::Program& program,
                                          const blobtree::GridSpec& grid, std::uint32_t brickCells,
                                          bool uniformRecords = true,
                                          ClassifyCode code = ClassifyCode::Interpreter, std::uint32_t forcedTiles = 0,
                                          std::uint32_t* tilesRun = nullptr);

struct ClassifiedBricks;

// The evaluator the batches run: options.traversal, or the cost model's choice for Auto with the
// code generation it chose (the vertex kernel's generated or interpreted gradient). Given the
// classified bricks, the model weighs the field at the active bricks' points only: a model whose
// surface fills a tenth of its grid evaluates a tenth of it, so an evaluator that builds slowly
// and runs fast pays back later than the whole grid says.
struct SparseEvaluator {
  Traversal traversal = Traversal::Auto;
  std::optional<CodegenOptions> codegen;  // empty: options.codegen was empty and not needed
  // On CPU drivers, the model's estimate for `traversal` (< 0: none; GpuStats reports them).
  double modelBuildSeconds = -1.0, modelRunSeconds = -1.0;
  // On CPU drivers, false where the field tiles' extra kernels (brick_tiles.h) would take longer
  // to build than they save over the job's active bricks: the field is then one kernel.
  bool fieldTiles = true;
  // The most tiles: options.maxFieldTiles, or repeatedJobFieldTiles where the finer plan pays.
  std::uint32_t fieldTileCap = 0;  // 0: options.maxFieldTiles
  // Tiles in all where looped tiles split on until they unroll: under Auto,
  // options.maxFieldTilesForLoopedCode where that pays, else 0 (none; a forced evaluator takes the
  // tiles maxFieldTiles gives).
  std::uint32_t loopedTileCap = 0;
  // Under Auto on CPU drivers, true where the field pass of a looped program (one over
  // kLoopedAboveInstructionsOnCpu instructions) runs faster over per-brick tapes
  // (options.brickTapes) than over its looped code or the tiles it splits into.
  bool brickTapes = false;
  // Under Auto on CPU drivers, without brickTapes: true where a looped program's vertex pass runs
  // faster over per-brick vertex tapes (options.vertexTapes) than over its looped code.
  bool vertexTapes = false;
  bool interpretVertexPassUntilBuilt = false;  // EvaluatorEstimate's
  void report(GpuStats& stats) const;
  // `options` with this evaluator; its codegen points into this object, which must outlive it.
  GpuPolygonizeOptions apply(const GpuPolygonizeOptions& options) const;
};
SparseEvaluator resolveSparseEvaluator(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                       const GpuPolygonizeOptions& options,
                                       const ClassifiedBricks* classified = nullptr);

// The classification's tables that the batches read, for a window of whole brick layers: the
// number of each brick row's first active brick and the list of active bricks. The flags and
// their scan, one word per brick, are a scratch of the classification and gone before the
// batches; with several windows each list is sized to its active bricks (a single window's holds
// room for all its bricks, one word each). A grid's tables are one window unless its
// flags would not fit one storage buffer (lavapipe's 128 MiB holds 33 M bricks; the tower at
// 4096³ in bricks of 8 cells has 81 M), and a batch's layers lie in one window. Numbers in a window count from its first
// active brick; the batches' kernels use only their differences, so the mesh does not depend on
// the windows.
struct ScanWindow {
  std::uint32_t firstLayer = 0, endLayer = 0;  // batches emitting layers within [firstLayer, endLayer) read it
  std::uint32_t activeBase = 0;                // the number of its first active brick in the whole grid
  // Of layers [firstLayer, min(endLayer + 2, layers)) (a batch loads the layer after the ones it
  // emits, and that layer's bricks look up their upper neighbours): per row of bricks (z, y), at
  // (z - firstLayer) * bricks.y + y, the number of its first active brick counted from the
  // window's, and one more word, the window's active count.
  Buffer rowStarts;
  // The active bricks of the same layers, packed (BrickGrid::pack), in (z, y, x) order: entry i is
  // brick activeBase + i, and a row's bricks ascend in x (brick_neighbours.comp searches them).
  Buffer list;
};

// The window of `windows` holding brick layers [firstLayer, endLayer); throws when none does.
const ScanWindow& windowHolding(std::span<const ScanWindow> windows, std::uint32_t firstLayer, std::uint32_t endLayer);

// Steps 1-2: the bricks classified and compacted on `device`, per window of brick layers (at most
// `windowLayers` each; 0: as many as one storage buffer holds), two submits each (count, then
// list), one for a single window; the coarser levels of bricks run with each window, over the
// layers under it. The tables stay on the device for the batches;
// layerStarts[z] is the number of the first active brick of brick layer z
// (layerStarts[bricks.z]: the active count). Sets the stats' activeBricks, classifySeconds
// (device time where the queue has timestamps, deviceTimed) and counts the submits.
// With `only`, the bricks outside that box are not classified and count as inactive: the batches
// then run (and number) the box's active bricks alone, in the same global order (the incremental
// re-run of an edit's bricks, incremental_extract.h); the tables are then one window.
struct ClassifiedBricks {
  BrickGrid bricks;
  std::vector<ScanWindow> windows;
  std::vector<std::uint32_t> layerStarts;
  std::uint64_t bytes = 0;         // device memory of the tables above, held through the batches
  std::uint64_t scratchBytes = 0;  // the flags, their scan and the parent levels, freed before the batches
  // True when the classification stopped at the first window with two adjacent layers over
  // ClassifyWatch::abandonPairsOver: the tables are incomplete, for classifyToFit to run again.
  bool abandoned = false;
  // The most device memory held at once: the classification's, or its tables with `batchBytes`.
  std::uint64_t peakBytes(std::uint64_t batchBytes) const;
  // Where batches must end: each window's end layer but the last.
  std::vector<std::uint32_t> windowEnds() const;
  // Active bricks [first, first + count) read back from the windows' lists, packed.
  std::vector<std::uint32_t> downloadList(Device& device, std::uint32_t first, std::uint32_t count) const;
};
// What the caller hears of a classification as it runs, and when it may stop.
struct ClassifyWatch {
  // (done, total) after each window of brick layers, when there are several.
  std::function<void(std::size_t done, std::size_t total)> progress;
  // Stop at the first window whose tables show `abandonLayers` adjacent layers (a pair, or one
  // layer) holding more active bricks than this (ClassifiedBricks::abandoned): the rest would be
  // classified for nothing when the caller then runs it again with smaller bricks.
  std::uint64_t abandonPairsOver = ~0ull;
  std::uint32_t abandonLayers = 2;
};
ClassifiedBricks classifyAndCompact(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                    const BrickGrid& bricks, GpuStats& stats, const BrickBox* only = nullptr,
                                    std::uint32_t windowLayers = 0, const ClassifyChoice& choice = {},
                                    const ClassifyWatch& watch = {});

// classifyAndCompact with bricks of `brickCells`, halved (down to 4) while `layersPerLoad`
// adjacent brick layers hold more active bricks than `rangeBricks(bricks)` (what one storage
// buffer holds, the least over the job's devices). A batch loads a layer pair (2), or, where its
// corners on the next layer may be matched by key (one device: planSparseBatches'
// KeyedBatches::Allow), a layer alone (1); a large grid's pair can exceed the range (lavapipe's
// 128 MiB range holds 6,829 bricks of 16³; the tower at 2048³ needs 6,885). Smaller bricks make
// thinner layers of smaller records, but evaluate more points per triangle, so one device keeps
// its bricks while single layers fit. The mesh does not depend on the brick size; the result's
// `bricks` is the grid used. A classification that can still halve its bricks stops at the
// first span over the range (ClassifyWatch::abandonPairsOver).
// `phaseNote` (GpuPolygonizeOptions::phaseNote) hears of each classification before it runs,
// `progress` (classifyProgress) of its windows.
ClassifiedBricks classifyToFit(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                               std::uint32_t brickCells, const std::function<std::uint64_t(const BrickGrid&)>& rangeBricks,
                               GpuStats& stats, std::uint32_t windowLayers = 0, const ClassifyChoice& choice = {},
                               const std::function<void(const std::string&)>& phaseNote = {},
                               const std::function<void(std::size_t done, std::size_t total)>& progress = {},
                               std::uint32_t layersPerLoad = 2);

mesh::TriMesh polygonizeSparse(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                               const GpuPolygonizeOptions& options, GpuStats* stats);
// polygonizeSparse into `mesh`'s arrays, cleared with their capacity kept (polygonizeInto).
void polygonizeSparseInto(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                          const GpuPolygonizeOptions& options, mesh::TriMesh& mesh, GpuStats* stats);

// What polygonizeSparse runs, batch by batch: each batch appends its vertices and its triangles
// (indices counted from the mesh's first vertex) to the mesh `into` returns, then `done` is
// called with the batch's number and the batch count. polygonizeSparse keeps one mesh; the
// streamed extraction (streamed_extract.h) hands each batch on and drops it. A batch with keyed
// corners (sparse_batches.h) appends its triangles as placeholders, filled in before the next
// batch's `done`: `meshOf(batch)` must then still give the mesh that holds them and the batch's
// vertex edge keys (the last batch's or the one before), each where the batch began appending.
struct SparseBatchSink {
  std::function<mesh::TriMesh&()> into;
  std::function<void(std::size_t batch, std::size_t batches)> done;
  std::function<mesh::TriMesh&(std::size_t batch)> meshOf;
  // `into` is one mesh every batch appends to (polygonizeSparse): its arrays, when they move,
  // take room for the job's estimated whole (SparseBatchRunner::run's reserveRatio).
  bool accumulates = false;
};
void runSparseExtraction(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const GpuPolygonizeOptions& options, const SparseBatchSink& sink, GpuStats& stats);

}  // namespace blobvk::vk
