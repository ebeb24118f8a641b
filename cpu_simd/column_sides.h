// Which columns of a box lie on one side of the iso-value: the host bound behind the Vulkan
// path's row culling on CPU drivers (vk::GpuPolygonizeOptions::columnSides). A box of grid points
// cut into n x n columns along y and z, each cut into nx segments along x, gets per segment 0
// where the field is below the iso-value at every point of its closed box, 1 where it is at or
// above it, 2 where it may cross. The program is pruned to the box (tape_pruning.h), then bounded
// per whole column, then per segment of the columns that may cross (block_bounds.h): as
// conservative as the MPU polygonizer's leaves, whose bits the GPU path's evaluation repeats.
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstdint>
#include <memory>

namespace blobvk::cpu {

class ColumnSides {
 public:
  // Whether an IEEE device (lavapipe: IEEE division and sqrt) evaluates `program` bit for bit as
  // the CPU does, so that these bounds, which contain the CPU's values, contain the device's: no
  // Ricci blend (pow) and no twist or bend warp (sin, cos), whose device functions differ.
  static bool boundsHoldOnIeeeDevices(const blobtree::Program& program);

  // `program` must outlive the object.
  explicit ColumnSides(const blobtree::Program& program);
  ~ColumnSides();
  ColumnSides(const ColumnSides&) = delete;
  ColumnSides& operator=(const ColumnSides&) = delete;

  // x: nx + 1 segment boundaries along x; y, z: n + 1 column boundaries each; all the float
  // coordinates of grid points (GridSpec::point), ascending. Writes sides[x + nx * (y + n * z)],
  // one per box of a segment and a column. Safe to call from several threads at once (each
  // thread keeps its own tape and bounds).
  void operator()(const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                  std::uint8_t* sides) const;

 private:
  struct State;
  const blobtree::Program& program_;
  std::unique_ptr<State> state_;
};

}  // namespace blobvk::cpu
