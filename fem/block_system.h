// The implicit system A = diag(nodeScale) + s K~ (+ contact blocks) assembled into 3x3 blocks
// over the node graph (two nodes are adjacent when they share a tet), for preconditioners that
// need the matrix itself. The solver still applies A matrix-free; this copy only builds the
// preconditioner. Rows are filled in parallel, one row per task, each summed in the incidence
// row's fixed order, so the values do not depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

class NodeIncidence;

struct BlockSystem {
  // Row r's blocks are [rowStart[r], rowStart[r+1]), sorted by column; diagonal[r] is the index
  // of block (r, r). Each block holds 9 values, row-major.
  std::vector<std::uint32_t> rowStart, column, diagonal;
  std::vector<double> values;
  std::size_t nodeCount() const { return diagonal.size(); }
  std::size_t blockCount() const { return column.size(); }
  // Index of block (r, c), or -1 when r and c share no tet.
  long find(std::size_t r, std::uint32_t c) const;
};

// The block pattern of a mesh: O(sum of squared incidence row lengths).
void buildBlockPattern(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                       BlockSystem& system);

}  // namespace blobvk::fem
