// For every node, the (tet, local corner) pairs that use it: the "pattern" of the matrix-free
// stiffness operator. Rows are kept sorted by tet so that per-node sums run in one fixed order
// (deterministic, and an incrementally edited set sums exactly like a freshly built one). Rows
// have spare capacity so that a topology change edits only the rows of the nodes it touches.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

class NodeIncidence {
 public:
  // Entries pack (tet << 2) | corner; tets must stay below 2^30.
  static std::uint32_t tetOf(std::uint32_t entry) { return entry >> 2; }
  static int cornerOf(std::uint32_t entry) { return int(entry & 3u); }

  // cutRoom: spare rows for later nodes, as a fraction (SimulationSettings::cutRoom).
  void build(std::size_t nodeCount, const std::vector<std::array<std::uint32_t, 4>>& tets, double cutRoom = 0.0);
  std::size_t nodeCount() const { return start_.size(); }
  void addNodes(std::size_t count);
  // Adds or removes the four entries of tet `tet` with these nodes: O(row length) per node.
  void addTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes);
  void removeTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes);
  // removeTet(tet, before) then addTet(tet, after), but a node in both keeps its row position
  // and only has its corner rewritten (a split tet keeps three of its four nodes).
  void replaceTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& before, const std::array<std::uint32_t, 4>& after);

  const std::uint32_t* begin(std::size_t node) const { return entries_.data() + start_[node]; }
  const std::uint32_t* end(std::size_t node) const { return entries_.data() + start_[node] + count_[node]; }
  std::uint32_t count(std::size_t node) const { return count_[node]; }

 private:
  // Moves a full row to the end of the storage with twice the room. The hole it leaves is not
  // reused: with geometric growth a row's holes stay below its live capacity (storage at most
  // ~2x), so there is no compaction pass (which would cost O(storage) in the middle of a cut).
  void grow(std::size_t node);
  void insertEntry(std::uint32_t node, std::uint32_t entry);  // keeps the row sorted
  void removeEntry(std::uint32_t node, std::uint32_t entry);

  std::vector<std::uint32_t> start_, count_, capacity_, entries_;
};

}  // namespace blobvk::fem
