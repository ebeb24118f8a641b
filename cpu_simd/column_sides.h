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
  // Whether these bounds contain an IEEE device's values (lavapipe: IEEE division and sqrt), not
  // only the CPU's. Without Ricci blends and twist or bend warps the device evaluates the program
  // bit for bit as the CPU does. A Ricci blend's pow differs from the C library's in the last
  // bits: the sides then keep kPowDeviceMargin between the bound and the iso-value, which holds
  // for powers up to 8.8: above, a child's power that one side flushes to 0 (below the smallest
  // normal float) and the other keeps moves the blend by 2^(-126/n), over half the margin
  // (0.0043 at n = 16), so no bound is claimed. The sin and cos of twists and bends move the
  // point the rest of the program sees: their bounds keep a thousandth of the radius of the turn
  // for them (more than Vulkan's 2^-11 error of sin and cos allows; llvmpipe's are about 1e-7).
  static bool boundsHoldOnIeeeDevices(const blobtree::Program& program);

  // The margin, in field units, between a proven side's bound and the iso-value for programs
  // with a Ricci blend, on top of the bounds' own rounding margin (1e-4 of the value): the row
  // culling that uses these sides runs on llvmpipe only, whose fields of such programs differ from
  // the CPU's by under 1e-6 of the value past 1 (tests/vk/test_row_culling.cpp holds Ricci blends
  // of powers 0.5 to 8 and the legacy tower fragment to a hundredth of this margin).
  static constexpr double kPowDeviceMargin = 1e-4;

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
  double margin_ = 0.0;  // kPowDeviceMargin where the program has a pow, else 0
  std::unique_ptr<State> state_;
};

}  // namespace blobvk::cpu
