// Uniform spatial hash over tet bounding boxes, so a sweep visits only the tets near the swept
// surface. Updated incrementally: inserting a tet adds its slot to the cells it overlaps and
// records its box; stale entries (slots whose content changed) are harmless because every hit is
// re-tested against the slot's current box. A cell that has doubled since it was last cleaned is
// cleaned when a query visits it (stale and repeated entries dropped), so the cost stays local to
// where the cutting happens: no whole-grid rebuild during a cutting session (only when the
// simulation moves the nodes).
#pragma once

#include "blobvk/cutting/flat_hash.h"
#include "blobvk/cutting/topology.h"

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace blobvk::cutting {

class SpatialGrid {
 public:
  // Cell size: twice the mean edge length of the live tets (at least 1e-12).
  void rebuild(const CutTopology& topology);
  // Registers the slot's current box. Call for every slot whose nodes or node positions changed
  // (renumbering to nodes at the same positions, as crack opening does, keeps the box).
  void insert(const CutTopology& topology, std::uint32_t slot);
  // For a slot whose new content lies inside the box of its previous nodes (a split's first
  // child in its parent's slot): records the new box only. The slot's entries, holding a larger
  // box in every cell the previous box meets, stay a conservative listing. Falls back to
  // insert() when rounding put a computed point a hair outside the previous box.
  void shrink(const CutTopology& topology, std::uint32_t slot, const Tet& previous);
  // For new slots whose content lies inside the box of `coveringPrevious`, the content that
  // `coveringSlot` held before a split (a split's further children): no entries of their own,
  // they join the covering slot's family instead, whose entries (never refreshed or dropped while
  // the family is not empty) hold that box or a larger one. A query that finds a slot also tests
  // its family, each member by the covering box it joined with (so a member is found wherever
  // its own entries would have found it, and sometimes where they would not: callers re-test
  // candidates exactly), and a member's own family only when the member passes (it lies inside
  // that box, or has entries of its own). One box per split instead of entries per child, and no
  // growth of the cells.
  void cover(const CutTopology& topology, std::span<const std::uint32_t> slots, std::uint32_t coveringSlot,
             const Tet& coveringPrevious);

  // For a slot about to be removed from the end of the topology (its content moved into a hole,
  // see LocalFlips): it leaves the family it is in (a later tet in that slot must not continue
  // that family's list), and the members of its own family, and theirs, get entries of their
  // own (the slot's entries no longer lead to them). Cost: the slot's family, not the grid.
  void release(const CutTopology& topology, std::uint32_t slot);

  // A thin region around a swept triangle: its box, its plane (unit normal through origin)
  // thickened by pad on both sides, and the three planes through its edges perpendicular to it
  // (outward unit normals through the edges' first vertices), moved out by pad: the prism over
  // the triangle. slabAround builds it.
  struct Slab {
    mesh::Double3 lo, hi, origin, normal;
    double pad = 0.0;
    std::array<mesh::Double3, 3> edgeNormal{}, edgeOrigin{};
  };
  static Slab slabAround(const std::array<mesh::Double3, 3>& triangle, double pad);
  // Live slots whose box meets some slab (box, thickened plane and prism), sorted and unique.
  // Only the cells that meet the slab are visited, a small part of a tilted triangle's box (and
  // about half of it for each of the two triangles of a swept quad), and the test reads the
  // slot's stored box (one record) rather than its four node positions. A superset of the tets
  // that meet a slab.
  void querySlabs(const CutTopology& topology, const std::vector<Slab>& slabs, std::vector<std::uint32_t>& out);

  // Safety valve only (cells are cleaned locally): far more entries than live tets.
  bool needsRebuild(const CutTopology& topology) const { return entries_ > 16 * topology.liveTetCount() + 4096; }
  double cellSize() const { return cell_; }

 private:
  // Box of a slot, rounded outwards to float (half the memory of doubles, still conservative).
  struct Box {
    std::array<float, 3> lo, hi;
  };
  static Box roundedOutwards(mesh::Double3 lo, mesh::Double3 hi);
  std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) const;
  std::int64_t cellOf(double v) const;
  // A cell lists its tets with their boxes as of insertion, so a query scans one contiguous
  // array and touches a slot's own data only for the entries whose box meets the slab. A stale
  // entry (the slot's content changed since) is harmless: a split child lies inside the box of
  // the parent that held its slot, any new content was inserted with its own box, and every
  // returned slot is re-tested exactly by the caller.
  struct Entry {
    std::uint32_t slot;
    Box box;
  };
  struct Cell {
    std::vector<Entry> entries;
    std::size_t cleanSize = 0;  // size after the last cleaning
  };
  void clean(const CutTopology& topology, std::uint64_t key, Cell& cell);
  void cleanIfGrown(const CutTopology& topology, std::uint64_t key);
  std::uint32_t cellIndexOf(std::uint64_t key);  // creates the cell if needed
  void nextStamp(const CutTopology& topology);
  template <typename F>
  void forEachSlabCell(const Slab& slab, F&& f) const;

  double cell_ = 1.0, inverseCell_ = 1.0;
  std::size_t entries_ = 0;
  FlatHashMap<std::uint64_t, std::uint32_t, U64Hash> cellIndex_{~0ull};  // cell key -> cells_ index
  std::vector<Cell> cells_;
  // Recently inserted-into cells (key, cells_ index); ~0 is never a cell key (bit 63).
  std::array<std::pair<std::uint64_t, std::uint32_t>, 8> recentCells_ = [] {
    std::array<std::pair<std::uint64_t, std::uint32_t>, 8> a{};
    a.fill({~0ull, 0});
    return a;
  }();
  std::uint32_t nextRecent_ = 0;
  std::vector<Box> boxes_;  // by slot, as of the slot's last insert (the current box)
  // Families (cover()): by slot, its first member and the next member of the family it belongs
  // to (kNone: none), and the box it joined with. A member's own family is a sub-family: it is
  // tested when the member is found. The previous member and the family's slot (kNone: in no
  // family) let release() unlink a member in O(1).
  std::vector<std::uint32_t> familyHead_, familyNext_, familyPrev_, familyOwner_;
  std::vector<Box> joinBox_;
  std::vector<std::uint32_t> familyStack_, sortScratch_;  // query scratch
  void growSlotArrays(std::size_t slots);
  std::vector<std::uint32_t> stamp_;
  std::uint32_t stampValue_ = 0;
};

}  // namespace blobvk::cutting
