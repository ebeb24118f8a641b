// Uniform spatial hash over tet bounding boxes, so a sweep visits only the tets near the swept
// surface. Updated incrementally: inserting a tet adds its slot to the cells it overlaps; stale
// entries (slots whose content changed) are harmless because candidates are re-tested exactly.
// A cell that has doubled since it was last cleaned is cleaned when a query visits it (stale and
// repeated entries dropped), so the cost stays local to where the cutting happens: no whole-grid
// rebuild during a cutting session (only when the simulation moves the nodes).
#pragma once

#include "cutting/topology.h"

#include <cstdint>
#include "cutting/flat_hash.h"

#include <vector>

namespace blobvk::cutting {

class SpatialGrid {
 public:
  // Cell size: twice the mean edge length of the live tets (at least 1e-12).
  void rebuild(const CutTopology& topology);
  void insert(const CutTopology& topology, std::uint32_t slot);
  // Live slots whose box overlaps [lo, hi] (deduplicated, unordered).
  void query(const CutTopology& topology, mesh::Double3 lo, mesh::Double3 hi, std::vector<std::uint32_t>& out);
  // Safety valve only (cells are cleaned locally): far more entries than live tets.
  bool needsRebuild(const CutTopology& topology) const { return entries_ > 16 * topology.liveTetCount() + 4096; }
  double cellSize() const { return cell_; }

 private:
  std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) const;
  std::int64_t cellOf(double v) const;
  struct Cell {
    std::vector<std::uint32_t> slots;
    std::size_t cleanSize = 0;  // size after the last cleaning
  };
  void clean(const CutTopology& topology, std::uint64_t key, Cell& cell);
  double cell_ = 1.0;
  std::size_t entries_ = 0;
  FlatHashMap<std::uint64_t, std::uint32_t, U64Hash> cellIndex_{~0ull};  // cell key -> cells_ index
  std::vector<Cell> cells_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t stampValue_ = 0;
};

}  // namespace blobvk::cutting
