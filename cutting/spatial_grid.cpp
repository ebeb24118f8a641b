#include "blobvk/cutting/spatial_grid.h"

#include "blobvk/cutting/prefault.h"
#include "blobvk/cutting/radix_sort.h"
#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace blobvk::cutting {
namespace {

// Float bounds that contain the double value: the stored boxes stay conservative.
// The float next to f towards -inf / +inf (as std::nextafter, without the libm call: these run
// six times per insert). f is finite or the infinity on the side away from the step.
float floatDown(float f) {
  if (f == 0.0f) return -std::numeric_limits<float>::denorm_min();
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(f);
  return std::bit_cast<float>(f > 0.0f ? bits - 1 : bits + 1);
}
float floatBelow(double v) {
  const float f = float(v);
  return double(f) <= v ? f : floatDown(f);
}
float floatAbove(double v) {
  const float f = float(v);
  return double(f) >= v ? f : -floatDown(-f);
}

// Bounding box of a tet's nodes (forced inline: GCC kept this and roundedOutwards out of line,
// +10% instructions in a rebuild's inserts).
[[gnu::always_inline]] inline void boxOfNodes(const std::vector<Double3>& p, const Tet& t, Double3& lo, Double3& hi) {
  lo = hi = p[t[0]];
  for (int i = 1; i < 4; ++i) {
    const Double3 q = p[t[i]];
    lo = {std::min(lo.x, q.x), std::min(lo.y, q.y), std::min(lo.z, q.z)};
    hi = {std::max(hi.x, q.x), std::max(hi.y, q.y), std::max(hi.z, q.z)};
  }
}

// Is the box [lo, hi] inside [outerLo, outerHi]?
bool inside(Double3 lo, Double3 hi, Double3 outerLo, Double3 outerHi) {
  return lo.x >= outerLo.x && lo.y >= outerLo.y && lo.z >= outerLo.z && hi.x <= outerHi.x && hi.y <= outerHi.y &&
         hi.z <= outerHi.z;
}

}  // namespace

[[gnu::always_inline]] inline SpatialGrid::Box SpatialGrid::roundedOutwards(Double3 lo, Double3 hi) {
  return {{floatBelow(lo.x), floatBelow(lo.y), floatBelow(lo.z)}, {floatAbove(hi.x), floatAbove(hi.y), floatAbove(hi.z)}};
}

std::int64_t SpatialGrid::cellOf(double v) const {
  // floor(v / cell) without the libm call (no SSE4.1 round instruction in the baseline ISA);
  // insertions and queries share this function, so they agree on every border.
  const double x = v * inverseCell_;
  const std::int64_t i = std::int64_t(x);
  return i - std::int64_t(double(i) > x);
}

std::uint64_t SpatialGrid::key(std::int64_t x, std::int64_t y, std::int64_t z) const {
  const std::uint64_t mask = (1ull << 21) - 1;
  return (std::uint64_t(x) & mask) | ((std::uint64_t(y) & mask) << 21) | ((std::uint64_t(z) & mask) << 42);
}

void SpatialGrid::rebuild(const CutTopology& topology) {
  cells_.clear();
  cellIndex_.clear();
  recentCells_.fill({~0ull, 0});
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
  inverseCell_ = 1.0 / cell_;
  // The per-slot arrays are sized once to the headroom for the tets a cutting session adds and
  // made resident (no growth, copy or page fault in the events); later rebuilds (every step the
  // simulation moves the nodes) reuse them as they are: a slot's box is written by its insert,
  // and only the family heads need resetting.
  if (boxes_.size() < topology.slotCount()) {
    const std::size_t room = topology.slotCount() + topology.slotCount() / 2 + 4096;
    boxes_.reserve(room);
    familyHead_.reserve(room);
    familyNext_.reserve(room);
    familyPrev_.reserve(room);
    familyOwner_.reserve(room);
    joinBox_.reserve(room);
    stamp_.reserve(room);
    growSlotArrays(room);
    prefaultCapacity(stamp_);
  }
  std::fill(familyHead_.begin(), familyHead_.end(), kNone);
  std::fill(familyOwner_.begin(), familyOwner_.end(), kNone);
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s)
    if (topology.alive(s)) insert(topology, s);
  for (Cell& c : cells_) c.cleanSize = c.entries.size();
}

void SpatialGrid::growSlotArrays(std::size_t slots) {
  if (boxes_.size() >= slots) return;
  const std::size_t size = std::max(slots, std::min(boxes_.capacity(), 2 * boxes_.size()));
  boxes_.resize(size);
  familyHead_.resize(size, kNone);
  familyNext_.resize(size, kNone);
  familyPrev_.resize(size, kNone);
  familyOwner_.resize(size, kNone);
  joinBox_.resize(size);
}

void SpatialGrid::nextStamp(const CutTopology& topology) {
  if (stamp_.size() < topology.slotCount())
    stamp_.resize(std::max(topology.slotCount(), std::min(stamp_.capacity(), 2 * stamp_.size())), 0);
  if (++stampValue_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    stampValue_ = 1;
  }
}

void SpatialGrid::clean(const CutTopology& topology, std::uint64_t cellKey, Cell& cell) {
  // Keep one entry per live slot whose current box still meets the cell, refreshed to that box
  // (a stamp round of its own).
  const std::int64_t mask = (1ll << 21) - 1;
  auto unpack = [&](int shift) {
    std::int64_t v = std::int64_t((cellKey >> shift) & std::uint64_t(mask));
    return v >= (1ll << 20) ? v - (1ll << 21) : v;  // cell coordinates are signed 21-bit
  };
  const double x0 = double(unpack(0)) * cell_, y0 = double(unpack(21)) * cell_, z0 = double(unpack(42)) * cell_;
  nextStamp(topology);
  std::size_t kept = 0;
  for (const Entry& entry : cell.entries) {
    const std::uint32_t s = entry.slot;
    if (s >= topology.slotCount() || !topology.alive(s)) continue;
    if (familyHead_[s] != kNone) {  // the entry covers the family too: kept as it is
      cell.entries[kept++] = entry;
      continue;
    }
    if (stamp_[s] == stampValue_) continue;
    const Box& b = boxes_[s];
    if (b.lo[0] > x0 + cell_ || b.lo[1] > y0 + cell_ || b.lo[2] > z0 + cell_ || b.hi[0] < x0 || b.hi[1] < y0 ||
        b.hi[2] < z0)
      continue;
    stamp_[s] = stampValue_;
    cell.entries[kept++] = {s, b};
  }
  entries_ -= cell.entries.size() - kept;
  cell.entries.resize(kept);
  cell.cleanSize = kept;
}

void SpatialGrid::cleanIfGrown(const CutTopology& topology, std::uint64_t cellKey) {
  const std::uint32_t* index = cellIndex_.find(cellKey);
  if (index != nullptr && cells_[*index].entries.size() > 2 * cells_[*index].cleanSize + 16)
    clean(topology, cellKey, cells_[*index]);
}

std::uint32_t SpatialGrid::cellIndexOf(std::uint64_t cellKey) {
  // The children of a split are inserted one after the other into the same few cells: a small
  // round-robin memo of recent cells saves most of the hash lookups.
  for (const auto& [k, index] : recentCells_)
    if (k == cellKey) return index;
  const auto [index, inserted] = cellIndex_.insert(cellKey, std::uint32_t(cells_.size()));
  if (inserted) cells_.emplace_back();
  recentCells_[nextRecent_++ % recentCells_.size()] = {cellKey, *index};
  return *index;
}

void SpatialGrid::shrink(const CutTopology& topology, std::uint32_t slot, const Tet& previous) {
  const auto& p = topology.mesh().positions;
  Double3 lo, hi, oldLo, oldHi;
  boxOfNodes(p, topology.tet(slot), lo, hi);
  boxOfNodes(p, previous, oldLo, oldHi);
  // Inside the previous box (doubles): the cells it meets and its rounded box are then within
  // the previous ones, which the slot's entries cover.
  if (slot >= boxes_.size() || !inside(lo, hi, oldLo, oldHi)) {
    insert(topology, slot);
    return;
  }
  boxes_[slot] = roundedOutwards(lo, hi);
}

void SpatialGrid::cover(const CutTopology& topology, std::span<const std::uint32_t> slots, std::uint32_t coveringSlot,
                        const Tet& coveringPrevious) {
  // Every member joins with the covering box itself: one box per split instead of one per child
  // (the query then tests a few more children; the cutter re-tests every candidate exactly). A
  // member's own box is needed only once it has entries, which insert() records.
  const auto& p = topology.mesh().positions;
  Double3 lo, hi;
  boxOfNodes(p, coveringPrevious, lo, hi);
  const Box box = roundedOutwards(lo, hi);
  for (const std::uint32_t slot : slots) {
    if (coveringSlot >= boxes_.size()) {
      insert(topology, slot);
      continue;
    }
    if (slot >= boxes_.size()) growSlotArrays(std::size_t(slot) + 1);
    joinBox_[slot] = box;
    const std::uint32_t head = familyHead_[coveringSlot];
    familyNext_[slot] = head;
    familyPrev_[slot] = kNone;
    if (head != kNone) familyPrev_[head] = slot;
    familyOwner_[slot] = coveringSlot;
    familyHead_[coveringSlot] = slot;
  }
}

void SpatialGrid::release(const CutTopology& topology, std::uint32_t slot) {
  if (slot >= boxes_.size()) return;
  if (const std::uint32_t owner = familyOwner_[slot]; owner != kNone) {
    const std::uint32_t prev = familyPrev_[slot], next = familyNext_[slot];
    (prev == kNone ? familyHead_[owner] : familyNext_[prev]) = next;
    if (next != kNone) familyPrev_[next] = prev;
    familyOwner_[slot] = kNone;
  }
  // The members lie inside boxes that only the slot's entries (and, below them, the members')
  // stood for: each gets its own, and leaves its family.
  std::vector<std::uint32_t>& pending = familyStack_;
  pending.clear();
  if (familyHead_[slot] != kNone) pending.push_back(familyHead_[slot]);
  familyHead_[slot] = kNone;
  while (!pending.empty()) {
    std::uint32_t m = pending.back();
    pending.pop_back();
    while (m != kNone) {
      const std::uint32_t next = familyNext_[m];
      familyOwner_[m] = kNone;
      if (familyHead_[m] != kNone) pending.push_back(familyHead_[m]);
      familyHead_[m] = kNone;
      if (m < topology.slotCount() && topology.alive(m)) insert(topology, m);
      m = next;
    }
  }
}

void SpatialGrid::insert(const CutTopology& topology, std::uint32_t slot) {
  const auto& p = topology.mesh().positions;
  Double3 lo, hi;
  boxOfNodes(p, topology.tet(slot), lo, hi);
  if (slot >= boxes_.size()) growSlotArrays(std::size_t(slot) + 1);
  const Box box = roundedOutwards(lo, hi);
  boxes_[slot] = box;
  // Cell ranges computed once (the loop bodies write memory: the compiler would recompute them).
  const std::int64_t x0 = cellOf(lo.x), x1 = cellOf(hi.x), y0 = cellOf(lo.y), y1 = cellOf(hi.y);
  const std::int64_t z0 = cellOf(lo.z), z1 = cellOf(hi.z);
  for (std::int64_t z = z0; z <= z1; ++z)
    for (std::int64_t y = y0; y <= y1; ++y)
      for (std::int64_t x = x0; x <= x1; ++x) {
        cells_[cellIndexOf(key(x, y, z))].entries.push_back({slot, box});
        ++entries_;
      }
}

namespace {

double l1(Double3 v) { return std::fabs(v.x) + std::fabs(v.y) + std::fabs(v.z); }

// Does the box (centre, half extents) meet the slab? Conservative: the slab's planes are moved
// out by `margin` besides the slab's own pad (rounding of the cell and box coordinates).
inline bool boxMeetsSlab(const SpatialGrid::Slab& slab, Double3 centre, Double3 half, double margin) {
  auto reach = [&](Double3 n) { return half.x * std::fabs(n.x) + half.y * std::fabs(n.y) + half.z * std::fabs(n.z); };
  if (std::fabs(dot(centre - slab.origin, slab.normal)) > reach(slab.normal) + slab.pad + margin) return false;
  for (int e = 0; e < 3; ++e)
    if (dot(centre - slab.edgeOrigin[std::size_t(e)], slab.edgeNormal[std::size_t(e)]) >
        reach(slab.edgeNormal[std::size_t(e)]) + slab.pad + margin)
      return false;
  return true;
}

}  // namespace

SpatialGrid::Slab SpatialGrid::slabAround(const std::array<Double3, 3>& t, double pad) {
  Slab slab;
  slab.lo = slab.hi = t[0];
  for (const Double3& p : t) {
    slab.lo = {std::min(slab.lo.x, p.x), std::min(slab.lo.y, p.y), std::min(slab.lo.z, p.z)};
    slab.hi = {std::max(slab.hi.x, p.x), std::max(slab.hi.y, p.y), std::max(slab.hi.z, p.z)};
  }
  slab.lo = slab.lo - Double3{pad, pad, pad};
  slab.hi = slab.hi + Double3{pad, pad, pad};
  const Double3 n = cross(t[1] - t[0], t[2] - t[0]);
  slab.normal = n * (1.0 / length(n));
  slab.origin = t[0];
  slab.pad = pad;
  for (std::size_t e = 0; e < 3; ++e) {
    const Double3 a = t[e], b = t[(e + 1) % 3];
    // Outward for a counter-clockwise triangle seen from the normal's side.
    const Double3 m = cross(b - a, slab.normal);
    const double len = length(m);
    slab.edgeOrigin[e] = a;
    // A degenerate edge constrains nothing (the other two and the box still bound the slab).
    slab.edgeNormal[e] = len > 0 ? m * (1.0 / len) : Double3{0, 0, 0};
  }
  return slab;
}

template <typename F>
void SpatialGrid::forEachSlabCell(const Slab& slab, F&& f) const {
  // A cell meets the slab when its centre is within its half-extent (plus pad) of the plane and
  // inside the prism; the margin covers the rounding of cellOf at cell borders and that of the
  // slab's normals.
  const Double3 half{0.5 * cell_, 0.5 * cell_, 0.5 * cell_};
  const double margin = 1e-6 * cell_ + 1e-12 * (l1(slab.lo) + l1(slab.hi));
  const std::int64_t x0 = cellOf(slab.lo.x), x1 = cellOf(slab.hi.x), y0 = cellOf(slab.lo.y), y1 = cellOf(slab.hi.y);
  const std::int64_t z0 = cellOf(slab.lo.z), z1 = cellOf(slab.hi.z);
  for (std::int64_t z = z0; z <= z1; ++z)
    for (std::int64_t y = y0; y <= y1; ++y)
      for (std::int64_t x = x0; x <= x1; ++x) {
        const Double3 centre{(double(x) + 0.5) * cell_, (double(y) + 0.5) * cell_, (double(z) + 0.5) * cell_};
        if (boxMeetsSlab(slab, centre, half, margin)) f(key(x, y, z));
      }
}

void SpatialGrid::querySlabs(const CutTopology& topology, const std::vector<Slab>& slabs,
                             std::vector<std::uint32_t>& out) {
  const std::size_t first = out.size();
  std::vector<std::uint32_t>& family = familyStack_;
  // Cleaning uses stamp rounds of its own, so it runs before the query's rounds.
  for (const Slab& slab : slabs) forEachSlabCell(slab, [&](std::uint64_t k) { cleanIfGrown(topology, k); });
  for (const Slab& slab : slabs) {
    nextStamp(topology);  // each slot is tested once per slab, however many cells list it
    const double margin = 1e-9 * cell_ + 1e-12 * (l1(slab.lo) + l1(slab.hi));
    // The slab's box rounded outwards to float: the entries' float boxes are compared without
    // conversions, all six sides at once (no branch per side; most entries fail one of them).
    const float lx = floatBelow(slab.lo.x), ly = floatBelow(slab.lo.y), lz = floatBelow(slab.lo.z);
    const float hx = floatAbove(slab.hi.x), hy = floatAbove(slab.hi.y), hz = floatAbove(slab.hi.z);
    auto passes = [&](const Box& b) {
      if ((b.lo[0] > hx) | (b.lo[1] > hy) | (b.lo[2] > hz) | (b.hi[0] < lx) | (b.hi[1] < ly) | (b.hi[2] < lz))
        return false;
      const Double3 centre{0.5 * (double(b.lo[0]) + b.hi[0]), 0.5 * (double(b.lo[1]) + b.hi[1]),
                           0.5 * (double(b.lo[2]) + b.hi[2])};
      const Double3 half{0.5 * (double(b.hi[0]) - b.lo[0]), 0.5 * (double(b.hi[1]) - b.lo[1]),
                         0.5 * (double(b.hi[2]) - b.lo[2])};
      return boxMeetsSlab(slab, centre, half, margin);
    };
    // The family of a found slot: each member tested by its joining box (its parent's, which
    // contains it); a member's sub-family lies inside that box too (or has entries of its own,
    // when rounding made the member insert itself later), so a member that fails prunes it.
    auto visitFamily = [&](std::uint32_t head) {
      family.clear();
      family.push_back(familyHead_[head]);
      while (!family.empty()) {
        std::uint32_t m = family.back();
        family.pop_back();
        for (; m != kNone; m = familyNext_[m]) {
          if (stamp_[m] == stampValue_ || !topology.alive(m) || !passes(joinBox_[m])) continue;
          stamp_[m] = stampValue_;
          out.push_back(m);
          if (familyHead_[m] != kNone) family.push_back(familyHead_[m]);
        }
      }
    };
    forEachSlabCell(slab, [&](std::uint64_t k) {
      const std::uint32_t* index = cellIndex_.find(k);
      if (index == nullptr) return;
      for (const Entry& entry : cells_[*index].entries) {
        const Box& b = entry.box;
        if ((b.lo[0] > hx) | (b.lo[1] > hy) | (b.lo[2] > hz) | (b.hi[0] < lx) | (b.hi[1] < ly) | (b.hi[2] < lz))
          continue;
        // A slot is listed in ~3 cells: settle repeats before the plane tests.
        const std::uint32_t s = entry.slot;
        if (s >= topology.slotCount() || stamp_[s] == stampValue_) continue;
        const Double3 centre{0.5 * (double(b.lo[0]) + b.hi[0]), 0.5 * (double(b.lo[1]) + b.hi[1]),
                             0.5 * (double(b.lo[2]) + b.hi[2])};
        const Double3 half{0.5 * (double(b.hi[0]) - b.lo[0]), 0.5 * (double(b.hi[1]) - b.lo[1]),
                           0.5 * (double(b.hi[2]) - b.lo[2])};
        if (!boxMeetsSlab(slab, centre, half, margin) || !topology.alive(s)) continue;
        stamp_[s] = stampValue_;
        out.push_back(s);
        if (familyHead_[s] != kNone) visitFamily(s);
      }
    });
  }
  if (first == 0) {  // the usual case: a radix sort (~1,100 slots; std::sort cost ~140 instructions each)
    radixSort(out, sortScratch_, std::uint32_t(topology.slotCount()), [](std::uint32_t slot) { return slot; });
  } else {
    std::sort(out.begin() + std::ptrdiff_t(first), out.end());
  }
  out.erase(std::unique(out.begin() + std::ptrdiff_t(first), out.end()), out.end());
}

}  // namespace blobvk::cutting
