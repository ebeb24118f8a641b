// Re-meshing after an edit (blobtree/edit.h): the per-MPU results of the last mesh are kept;
// an update re-polygonizes only the MPUs that the edit's region touches and splices their rows
// into the previous mesh in place. The mesh after every update is byte-identical to
// polygonizeMpu(program, grid, options) of the edited tree (tests/cpu_simd/test_incremental_*).
//
// The grid is fixed for the session: an edit that moves geometry past the grid's bounds is
// clipped there, as a full polygonization on the same grid would be. Start a new session (a
// new grid from the edited Program's bounds) to follow the model.
#pragma once

#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/mesh/trimesh.h"

#include <cstddef>
#include <cstdint>
#include <memory>

namespace blobvk::cpu {

struct IncrementalStats {
  std::size_t mpus = 0;           // MPUs in the grid
  std::size_t mpusRerun = 0;      // MPUs the region touched, polygonized again
  std::size_t mpusRewritten = 0;  // MPUs whose triangles were written again (re-run or a neighbour was)
  bool full = false;              // the region covered so much that the whole grid was re-meshed
  std::uint64_t verticesMoved = 0, trianglesMoved = 0;  // elements shifted in place by the splice
  // Wall-clock per phase (ms): re-running MPUs, and the splice: planning, moving clean runs,
  // shifting corner indices, writing the new segments.
  double msPolygonize = 0, msSplice = 0, msTotal = 0;
  double msPlan = 0, msMove = 0, msShift = 0, msWrite = 0;
};

class IncrementalPolygonizer {
 public:
  // Validated by the first reset (as polygonizeMpu validates).
  IncrementalPolygonizer(const blobtree::GridSpec& grid, const MpuOptions& options = {});
  ~IncrementalPolygonizer();
  IncrementalPolygonizer(const IncrementalPolygonizer&) = delete;
  IncrementalPolygonizer& operator=(const IncrementalPolygonizer&) = delete;

  // Polygonizes the whole grid (polygonizeMpu's mesh) and keeps what an update needs.
  const mesh::TriMesh& reset(const blobtree::Program& program, MpuStats* stats = nullptr);

  // `program` differs from the previous one only inside `region` (EditableTree::apply's
  // answer). Re-runs the MPUs whose box, grown by one cell, meets the region, and splices.
  // Throws std::logic_error before the first reset.
  const mesh::TriMesh& update(const blobtree::Program& program, const blobtree::Region& region,
                              IncrementalStats* stats = nullptr);

  const mesh::TriMesh& mesh() const;
  const blobtree::GridSpec& grid() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace blobvk::cpu
