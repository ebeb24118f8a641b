// Per-node lists of incident tets in one pooled array (replacing a std::vector per node: one
// allocation per node and a pointer chase per lookup). Each node owns a run [offset, offset +
// capacity) of the pool; a full run moves to the end of the pool with twice the capacity, and the
// pool is compacted when abandoned runs exceed half of it, so memory stays O(entries) and pushes
// are amortised O(1).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::cutting {

class IncidenceLists {
 public:
  // Lays out runs for `capacities.size()` nodes back to back (the initial mesh: no moves later
  // unless a node gains more tets than its capacity).
  void layout(const std::vector<std::uint32_t>& capacities);
  std::size_t nodeCount() const { return runs_.size(); }
  void addNode() { runs_.emplace_back(); }

  std::span<const std::uint32_t> of(std::uint32_t node) const {
    const Run& r = runs_[node];
    return {pool_.data() + r.offset, r.size};
  }

  // Inline fast path (a cut event makes ~7,000 pushes); a full run moves out of line.
  void push(std::uint32_t node, std::uint32_t item) {
    if (runs_[node].size == runs_[node].capacity) grow(node);
    Run& run = runs_[node];
    pool_[run.offset + run.size++] = item;
    ++entries_;
  }
  // Removes one occurrence of item (order not kept); false when absent.
  bool remove(std::uint32_t node, std::uint32_t item);
  std::size_t totalEntries() const { return entries_; }

 private:
  struct Run {
    std::uint32_t offset = 0, size = 0, capacity = 0;
  };
  void compact();
  // Moves the node's full run to the end of the pool with twice the room.
  void grow(std::uint32_t node);

  std::vector<Run> runs_;
  std::vector<std::uint32_t> pool_;
  std::size_t abandoned_ = 0, entries_ = 0;
};

}  // namespace blobvk::cutting
