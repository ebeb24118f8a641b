// The multi-core polygonizer: the grid is cut into MPUs (blocks of D^3 cells) processed in
// parallel on TBB, each with a conservative early discard (field_bounds.h), a SIMD field cache,
// a case index per cell and per-edge vertices. The output is one welded mesh equal to
// polygonizeReference's: vertices in global edge-key order, triangles in cell order, the same
// bytes for any thread count.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/mesh/trimesh.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

namespace blobvk::cpu {

inline constexpr int kDefaultMpuCells = 16;  // chosen by bench_polygonizer's MPU-size sweep
inline constexpr int kDefaultSubBlockCells = 4;  // 16 -> 8 -> 4: bench_polygonizer's subblock_sweep
// A whole mesh in one job (blobvk mesh, bench, compare): larger MPUs halved down to leaves of 3
// cells (24 -> 12 -> 6 -> 3) evaluate about a third fewer points than the default at the same
// time (docs/performance.md). Re-running MPUs after an edit favours the smaller default.
inline constexpr int kWholeMeshMpuCells = 24;
inline constexpr int kWholeMeshSubBlockCells = 3;

struct MpuOptions {
  int mpuCells = kDefaultMpuCells;  // D: cells per MPU side, 2..64
  int threads = 0;                  // 0: all cores (tbb default concurrency)
  bool normals = true;
  bool colours = true;
  int refineSteps = 0;        // as ReferenceOptions::refineSteps (Illinois steps per edge)
  bool earlyDiscard = true;   // the conservative interval test per MPU
  bool pruneTapes = true;     // evaluate each MPU with the code specialised to its box
  // Sparse field cache: each MPU is halved recursively down to blocks of this many cells; a
  // block whose interval bound classifies it (all outside or all inside) is not evaluated, so
  // only the points of blocks near the surface are (0: every grid point of the MPU is).
  int subBlockCells = kDefaultSubBlockCells;
  std::optional<SimdLevel> simd;  // default: bestSimdLevel()
  float normalStep = 1e-4f;   // margin around each MPU within which its pruned tapes stay exact
  // Called as groups of MPUs finish (done of total), from TBB worker threads, possibly at once
  // from several: the callee synchronises. For progress display; it must not throw.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

struct MpuStats {
  // Point evaluations of the field: grid points sampled, refinement steps on edges, attribute
  // evaluations (1 per vertex: one analytic-gradient pass gives the normal and the colour).
  std::uint64_t gridEvaluations = 0, edgeEvaluations = 0, attributeEvaluations = 0;
  std::uint64_t pointEvaluations = 0;  // the sum of the three
  std::uint64_t simdBlocks = 0;        // SIMD calls (point evaluations / lane width, rounded up)
  std::uint64_t triangles = 0, vertices = 0;
  double fvept = 0.0;      // point evaluations per triangle
  double fveptSimd = 0.0;  // SIMD calls per triangle (the thesis' count)
  std::uint64_t mpus = 0, discardedEmpty = 0, discardedFull = 0, empty = 0, full = 0, crossed = 0;
  // Pruned-tape instructions summed over the MPUs that were evaluated; sub-blocks bounded and
  // how many of them the bound classified (their points were not evaluated).
  std::uint64_t tapeInstructions = 0, subBlocks = 0, subBlocksClassified = 0;
  int mpuCells = 0, threads = 0;
  SimdLevel simd = SimdLevel::Scalar;
  // Wall-clock per phase (ms).
  double msSetup = 0, msMpus = 0, msPrefix = 0, msScatter = 0, msTotal = 0;
  // CPU time summed over threads inside the MPU phase (ms).
  double cpuDiscard = 0, cpuPrune = 0, cpuField = 0, cpuCells = 0, cpuVertices = 0, cpuAttributes = 0;
};

mesh::TriMesh polygonizeMpu(const blobtree::Program& program, const blobtree::GridSpec& grid,
                            const MpuOptions& options = {}, MpuStats* stats = nullptr);

// polygonizeMpu for a host that meshes again (an editor's full re-mesh, an animation, a
// benchmark's repeats): the object keeps its per-thread scratch and every MPU's result arrays,
// and `out`'s arrays keep their capacity, so after the first mesh a mesh of about the same size
// allocates nothing and takes no page faults. The mesh is polygonizeMpu's, byte for byte; if
// polygonize throws (polygonizeMpu's errors), `out` holds no meaningful mesh and the object
// stays usable. One polygonize at a time per object.
class MpuPolygonizer {
 public:
  MpuPolygonizer();
  ~MpuPolygonizer();
  MpuPolygonizer(MpuPolygonizer&&) noexcept;
  MpuPolygonizer& operator=(MpuPolygonizer&&) noexcept;

  void polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                  const MpuOptions& options, mesh::TriMesh& out, MpuStats* stats = nullptr);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace blobvk::cpu
