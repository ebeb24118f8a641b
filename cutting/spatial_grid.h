// Uniform spatial hash over tet bounding boxes, so a sweep visits only the tets near the swept
// surface. Updated incrementally: inserting a tet adds its slot to the cells it overlaps; stale
// entries (slots whose content changed) are harmless because candidates are re-tested exactly,
// and the grid is rebuilt when stale entries outnumber live ones.
#pragma once

#include "cutting/topology.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace blobvk::cutting {

class SpatialGrid {
 public:
  // Cell size: twice the mean edge length of the live tets (at least 1e-12).
  void rebuild(const CutTopology& topology);
  void insert(const CutTopology& topology, std::uint32_t slot);
  // Live slots whose box overlaps [lo, hi] (deduplicated, unordered).
  void query(const CutTopology& topology, mesh::Double3 lo, mesh::Double3 hi, std::vector<std::uint32_t>& out);
  bool needsRebuild(const CutTopology& topology) const { return entries_ > 4 * topology.liveTetCount() + 1024; }
  double cellSize() const { return cell_; }

 private:
  std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) const;
  std::int64_t cellOf(double v) const;
  double cell_ = 1.0;
  std::size_t entries_ = 0;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t stampValue_ = 0;
};

}  // namespace blobvk::cutting
