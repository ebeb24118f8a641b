// The implicit system A = diag(nodeScale) + s K~ (+ contact) assembled once per step as 3x3
// blocks over the node graph, so that each CG iteration is one streaming block-sparse product
// instead of a per-tet pass plus a per-node gather (~2x less memory traffic; docs/fem.md).
// Off-diagonal blocks are stored in float: the product reads half the bytes. The diagonal
// blocks stay double and are *derived* as minus the sum of the row's float off-diagonal blocks
// (K~'s rows sum to zero, sum_j h_j = 0 per tet), plus mass and contact: K~ annihilates rigid
// translations exactly, whatever the rounding of the off-diagonals, so free fall and gravity see
// no spurious stiffness. Rows are independent and summed in the incidence order: results do not
// depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

class NodeIncidence;

class SystemMatrix {
 public:
  // The pattern of the current tets: per node, its neighbours (nodes sharing a tet) sorted,
  // and per tet corner pair (a, b) the index of t[b] in row t[a]. Values are left unset. Rows
  // get spare room (half their length) for later edits.
  void buildPattern(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets);
  // After a topology change: rebuilds only the given rows (sorted, unique; every node whose
  // incident tets changed, new nodes included) and the slots of the tet corners in them. A row
  // that outgrows its room moves to the end of the storage with twice the room (as
  // NodeIncidence's rows do). Rows of other nodes, and their slots, are unchanged by the change.
  void updateRows(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                  const std::vector<std::uint32_t>& rows);
  std::size_t nodeCount() const { return diagonal_.size() / 9; }

  // The storage a product reads (system_matrix.cpp's kernels).
  struct Rows {
    const std::uint32_t *start, *length, *column;
    const float* offDiagonal;
    const double* diagonal;
  };

  // y = A p (3 values per node); multiplyRows: rows [begin, end) only. AVX2 + FMA where the CPU
  // has them (picked once), else a scalar loop; the two differ in the last bits only.
  void multiply(const double* p, double* y) const;
  void multiplyRows(std::size_t begin, std::size_t end, const double* p, double* y) const;

  // Storage the assembly writes (ElementSet::assembleMatrix) and contact adds to.
  std::uint32_t rowBegin(std::size_t node) const { return rowStart_[node]; }
  std::uint32_t rowEnd(std::size_t node) const { return rowStart_[node] + rowLength_[node]; }
  std::uint32_t column(std::uint32_t k) const { return column_[k]; }
  // Block index, within row t[a] (from rowBegin), of column t[b]; a != b.
  std::uint16_t slot(std::size_t tet, int a, int b) const { return tetSlots_[tet][std::size_t(4 * a + b)]; }
  float* offDiagonal(std::uint32_t k) { return offDiagonal_.data() + 9 * std::size_t(k); }
  const float* offDiagonal(std::uint32_t k) const { return offDiagonal_.data() + 9 * std::size_t(k); }
  double* diagonal(std::size_t node) { return diagonal_.data() + 9 * node; }
  const double* diagonal(std::size_t node) const { return diagonal_.data() + 9 * node; }
  std::size_t longestRow() const { return longestRow_; }

 private:
  // The sorted neighbours of rows[k], written at bound[k] in scratch; their count in length[k].
  static void sortedRows(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                         const std::vector<std::uint32_t>& rows, std::vector<std::uint32_t>& bound,
                         std::vector<std::uint32_t>& length, std::vector<std::uint32_t>& scratch);
  // The slots of every (tet, corner) of node's incidence row, from its (final) row.
  void computeSlots(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                    std::size_t node);
  // Storage for a row of `length` at the end, with twice the room.
  void moveRowToEnd(std::size_t node, std::uint32_t length);

  std::vector<std::uint32_t> rowStart_, rowLength_, rowCapacity_, column_;
  std::vector<std::array<std::uint16_t, 16>> tetSlots_;
  std::vector<float> offDiagonal_;  // 9 per block, row-major
  std::vector<double> diagonal_;    // 9 per node, row-major
  std::size_t longestRow_ = 0;
};

}  // namespace blobvk::fem
