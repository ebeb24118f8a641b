#include "cutting/spatial_grid.h"

#include "cutting/vec.h"

#include <algorithm>
#include <cmath>

namespace blobvk::cutting {
namespace {

void tetBox(const CutTopology& topo, std::uint32_t slot, Double3& lo, Double3& hi) {
  const auto& p = topo.mesh().positions;
  const Tet& t = topo.tet(slot);
  lo = hi = p[t[0]];
  for (int i = 1; i < 4; ++i) {
    const Double3 q = p[t[i]];
    lo = {std::min(lo.x, q.x), std::min(lo.y, q.y), std::min(lo.z, q.z)};
    hi = {std::max(hi.x, q.x), std::max(hi.y, q.y), std::max(hi.z, q.z)};
  }
}

}  // namespace

std::int64_t SpatialGrid::cellOf(double v) const { return std::int64_t(std::floor(v / cell_)); }

std::uint64_t SpatialGrid::key(std::int64_t x, std::int64_t y, std::int64_t z) const {
  const std::uint64_t mask = (1ull << 21) - 1;
  return (std::uint64_t(x) & mask) | ((std::uint64_t(y) & mask) << 21) | ((std::uint64_t(z) & mask) << 42);
}

void SpatialGrid::rebuild(const CutTopology& topology) {
  cells_.clear();
  cellIndex_.clear();
  entries_ = 0;
  double sum = 0.0;
  std::size_t count = 0;
  const auto& p = topology.mesh().positions;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s) {
    if (!topology.alive(s)) continue;
    const Tet& t = topology.tet(s);
    sum += length(p[t[0]] - p[t[1]]) + length(p[t[2]] - p[t[3]]);
    count += 2;
  }
  cell_ = std::max(1e-12, count ? 2.0 * sum / double(count) : 1.0);
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s)
    if (topology.alive(s)) insert(topology, s);
  for (Cell& c : cells_) c.cleanSize = c.slots.size();
}

void SpatialGrid::clean(const CutTopology& topology, std::uint64_t key, Cell& cell) {
  // Keep live slots whose current box still meets the cell, once each (stamps of a fresh query
  // round, so the caller's own round is unaffected: it re-stamps after).
  const std::int64_t mask = (1ll << 21) - 1;
  auto unpack = [&](int shift) {
    std::int64_t v = std::int64_t((key >> shift) & std::uint64_t(mask));
    return v >= (1ll << 20) ? v - (1ll << 21) : v;  // cell coordinates are signed 21-bit
  };
  const double x0 = double(unpack(0)) * cell_, y0 = double(unpack(21)) * cell_, z0 = double(unpack(42)) * cell_;
  if (++stampValue_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    stampValue_ = 1;
  }
  std::size_t kept = 0;
  for (std::uint32_t s : cell.slots) {
    if (s >= topology.slotCount() || !topology.alive(s) || stamp_[s] == stampValue_) continue;
    Double3 lo, hi;
    tetBox(topology, s, lo, hi);
    if (lo.x > x0 + cell_ || lo.y > y0 + cell_ || lo.z > z0 + cell_ || hi.x < x0 || hi.y < y0 || hi.z < z0) continue;
    stamp_[s] = stampValue_;
    cell.slots[kept++] = s;
  }
  entries_ -= cell.slots.size() - kept;
  cell.slots.resize(kept);
  cell.cleanSize = kept;
}

void SpatialGrid::insert(const CutTopology& topology, std::uint32_t slot) {
  Double3 lo, hi;
  tetBox(topology, slot, lo, hi);
  for (std::int64_t z = cellOf(lo.z); z <= cellOf(hi.z); ++z)
    for (std::int64_t y = cellOf(lo.y); y <= cellOf(hi.y); ++y)
      for (std::int64_t x = cellOf(lo.x); x <= cellOf(hi.x); ++x) {
        const auto [index, inserted] = cellIndex_.insert(key(x, y, z), std::uint32_t(cells_.size()));
        if (inserted) cells_.emplace_back();
        cells_[*index].slots.push_back(slot);
        ++entries_;
      }
}

void SpatialGrid::query(const CutTopology& topology, Double3 lo, Double3 hi, std::vector<std::uint32_t>& out) {
  if (stamp_.size() < topology.slotCount()) stamp_.resize(topology.slotCount() + topology.slotCount() / 4, 0);
  // Clean the visited cells that doubled first (each cleaning uses its own stamp round).
  for (std::int64_t z = cellOf(lo.z); z <= cellOf(hi.z); ++z)
    for (std::int64_t y = cellOf(lo.y); y <= cellOf(hi.y); ++y)
      for (std::int64_t x = cellOf(lo.x); x <= cellOf(hi.x); ++x) {
        const std::uint32_t* index = cellIndex_.find(key(x, y, z));
        if (index != nullptr && cells_[*index].slots.size() > 2 * cells_[*index].cleanSize + 16)
          clean(topology, key(x, y, z), cells_[*index]);
      }
  if (++stampValue_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    stampValue_ = 1;
  }
  for (std::int64_t z = cellOf(lo.z); z <= cellOf(hi.z); ++z)
    for (std::int64_t y = cellOf(lo.y); y <= cellOf(hi.y); ++y)
      for (std::int64_t x = cellOf(lo.x); x <= cellOf(hi.x); ++x) {
        const std::uint32_t* index = cellIndex_.find(key(x, y, z));
        if (index == nullptr) continue;
        for (std::uint32_t s : cells_[*index].slots) {
          if (s >= topology.slotCount() || !topology.alive(s) || stamp_[s] == stampValue_) continue;
          stamp_[s] = stampValue_;
          Double3 tlo, thi;
          tetBox(topology, s, tlo, thi);
          if (tlo.x > hi.x || tlo.y > hi.y || tlo.z > hi.z || thi.x < lo.x || thi.y < lo.y || thi.z < lo.z) continue;
          out.push_back(s);
        }
      }
}

}  // namespace blobvk::cutting
