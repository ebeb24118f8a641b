// The sparse path's classification on the host on llvmpipe: a brick is active
// where the caller's bound (GpuPolygonizeOptions::columnSides, the CPU backend's, which row
// culling already trusts on llvmpipe) says the field over its closed box of grid points may
// reach the iso-value; the tables the batches read (sparse_polygonizer.h, ScanWindow) are then
// written by the host into one window.
//
// Why: on lavapipe the device's classification is a kernel like any other, whose first dispatch
// in a process builds it (cold: LLVM compiles the interval interpreter, 0.8-1 s on 2 cores; warm:
// 20-30 ms of pipeline creation), and whose every bound runs the interpreter lane by lane. The
// host bounds blocks of 4^3 bricks, then the bricks of the blocks that may cross, in a few
// milliseconds (2 ms for eggshell at 512 cells, 11-12 ms for tower, 27-31 ms for random128,
// against 10-12, 45-57 and 61-69 ms on the device; `blobvk bench ... --json`,
// vk_phases.classification_s). The bound is conservative, as the device's: every brick with a
// crossing edge is active either way, and an active brick without one adds nothing, so the mesh
// is the same bytes (the two disagree only about bricks the surface does not cross: tower at 512
// cells has 4,927 active bricks by the host's bound, 5,892 by the device's).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>

namespace blobvk::vk {

// Grids of at most this many bricks classify on the host where they may (classifiesOnHost): one
// window's tables (sparse_polygonizer.h, ScanWindow) hold them, and a flag a brick is 16 MB.
inline constexpr std::uint64_t kHostClassifyMaxBricks = 1u << 24;

// Whether `bricks` of this job classify on the host: llvmpipe (whose float division and sqrt the
// bound's contract assumes, as for row culling) with `options.columnSides` given and
// `options.hostPassesOnCpuDevices`, no windows asked for (`options.windowLayers` 0), and at most
// kHostClassifyMaxBricks bricks.
bool classifiesOnHost(const Device& device, const GpuPolygonizeOptions& options, const BrickGrid& bricks);

// classifyAndCompact's result for the whole grid (one window), from `options.columnSides`: a
// brick's side over the box of its grid points clipped to the grid. Deterministic; the watch's
// abandon rule as classifyAndCompact's. Sets the stats' activeBricks and classifySeconds (host
// wall time).
ClassifiedBricks classifyOnHost(Device& device, const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid,
                                const BrickGrid& bricks, GpuStats& stats, const ClassifyWatch& watch = {});

}  // namespace blobvk::vk
