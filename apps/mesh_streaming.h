// `blobvk mesh` out of core: the cpu backend's mesh written layer by layer of MPUs
// (cpu_simd/streaming_polygonizer.h), or the vk backend's batch by batch of brick layers
// (vk/extract/streamed_extract.h), into a streamed file (mesh/streamed_writer.h), with the
// streamed mesh check beside it, so peak memory is a few layers instead of the whole mesh.
#pragma once

#include "backends.h"
#include "resource_limits.h"

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/checks.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>

namespace blobvk::app {

// Upper estimate of a streamed job's working set: two layers of output plus one of MPU results
// (the in-memory estimate's surface density spread evenly over the layers), the per-layer row
// tables and the per-MPU result slots.
std::uint64_t estimateStreamedBytes(const blobtree::GridSpec& grid, int mpuCells);

// --resolution for `mesh`: the finest N whose streamed estimate fits in physical memory (the
// in-memory limit of resolution_limit.h is for commands that hold the mesh).
CLI::Validator meshResolutionRange();

struct StreamedMeshResult {
  double seconds = 0, pointEvaluations = 0;
  std::uint64_t vertices = 0, triangles = 0, bytes = 0;
  std::optional<mesh::MeshReport> report;  // when asked for
  std::optional<PolygonizeStats::Phases> gpu;  // vk: batches, bricks, device bytes, evaluator
  int ranks = 1;        // MPI ranks that shared the layers (mesh_mpi.h)
  bool worker = false;  // this process is an MPI rank other than 0: it wrote nothing
};

// Polygonizes with the cpu backend's settings (over MPI ranks when started by mpirun), or the vk
// backend's (one process, one device), into `out` ("-": standard output) as `format`
// (ply, obj, stl; asciiPly for ASCII PLY). Throws before writing anything past --max-triangles.
StreamedMeshResult meshStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const PolygonizeSettings& settings, const std::string& out,
                                const std::string& format, bool asciiPly, bool check, const Limits& limits);

}  // namespace blobvk::app
