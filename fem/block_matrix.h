// Symmetric-pattern sparse matrix of 3x3 blocks (block CSR) whose pattern is built once from the
// tets; each step only refills values through per-element slot indices (no triplets, no sort).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

class BlockMatrix3 {
 public:
  // Pattern: block (i, j) exists when nodes i and j share a tet (including i == j).
  void build(std::size_t nodeCount, const std::vector<std::array<std::uint32_t, 4>>& tets);

  std::size_t rows() const { return rowStart_.empty() ? 0 : rowStart_.size() - 1; }
  std::size_t blockCount() const { return columns_.size(); }
  // Block index of (tet t, local i, local j), i and j in 0..3.
  std::uint32_t slot(std::size_t tet, int i, int j) const { return slots_[tet * 16 + std::size_t(i * 4 + j)]; }
  std::uint32_t diagonal(std::size_t row) const { return diagonal_[row]; }
  double* block(std::uint32_t index) { return values_.data() + std::size_t(index) * 9; }  // row-major 3x3
  const double* block(std::uint32_t index) const { return values_.data() + std::size_t(index) * 9; }
  void setZero();
  // y = A x over 3 * rows() values, in parallel over block rows.
  void multiply(const double* x, double* y) const;

 private:
  std::vector<std::uint32_t> rowStart_, columns_, diagonal_, slots_;
  std::vector<double> values_;
};

}  // namespace blobvk::fem
