// Local improvement of the tets a cut event made (Klingner & Shewchuk 2007's topological
// operations, restricted to what a running FEM takes without deleting a tet slot): a tet whose
// smallest dihedral angle at rest is below a threshold is replaced, with a neighbour, by the
// best of
//   - face removal (2-3 flip): the tet and the tet across one of its interior faces become three
//     tets around the edge joining their apexes;
//   - edge removal (n -> 2n - 4, n = 3..7 tets around an interior edge): the ring of tets around
//     one of its edges becomes the cones from the edge's two ends over the best triangulation of
//     the ring's polygon (every triangulation tried). The 3-2 flip (n = 3) frees a slot, which a
//     running FEM cannot take: only when an earlier flip of the event appended the last slot,
//     which is then given back (its content moves into the freed one).
// An operation is taken when it raises the smallest dihedral angle of the tets it replaces, and
// only where every tet it touches has the same region, every new tet is positive at rest and in
// the current positions, and no new edge exists elsewhere. It keeps the nodes, the boundary (crack
// faces included: they are boundary faces once the crack is open), the parts and the union of
// the replaced tets, so the mesh stays conforming and its volume is kept to rounding.
// Deterministic: seeds in slot order, then the tets each operation writes, first in first out.
#pragma once

#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/topology.h"

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::cutting {

// The smallest of the six dihedral angles of the tet (a, b, c, d), in degrees.
double minDihedralDeg(mesh::Double3 a, mesh::Double3 b, mesh::Double3 c, mesh::Double3 d);
// -cos of that angle: increases with it, without an acos (the flips' and smoothing's measure).
double dihedralQuality(mesh::Double3 a, mesh::Double3 b, mesh::Double3 c, mesh::Double3 d);

struct FlipStats {
  std::size_t faceRemovals = 0, edgeRemovals = 0, threeTwo = 0, attempts = 0;  // threeTwo: within edgeRemovals
};

// The change set of a cut event, appended to by the flips (see CutResult): a slot written for the
// first time in the event is listed as removed (with its nodes before) and added; a new slot as
// added.
struct FlipChangeSet {
  std::vector<std::uint32_t>& removedTets;
  std::vector<Tet>& removedTetNodes;
  std::vector<std::uint32_t>& addedTets;
};

class LocalFlips {
 public:
  // Improves the tets of `seeds` (sorted slots) below `belowDeg`, with at most `maxAttempts`
  // attempted tets (the bound on an event's cost). Updates the topology, registers every written
  // slot in the grid and appends to the change set, whose addedTets already hold the slots the
  // event wrote (they are not listed as removed again).
  FlipStats improve(CutTopology& topology, SpatialGrid& grid, std::span<const std::uint32_t> seeds, double belowDeg,
                    std::size_t maxAttempts, FlipChangeSet change);

 private:
  // One attempt on the tet in `slot` when its smallest dihedral angle has a cosine above
  // belowCosine (the threshold's, computed once per call).
  bool improveTet(CutTopology& topology, std::uint32_t slot, double belowCosine, FlipStats& stats);
  void write(CutTopology& topology, std::uint32_t slot, const Tet& nodes);
  std::uint32_t append(CutTopology& topology, const Tet& nodes, std::uint32_t region);
  // A 3-2 flip frees a slot, which a running FEM cannot take: it is done only when the last slot
  // was appended by a flip of this call (and has the ring's region), and that slot is given back.
  // (Giving back a slot a split appended needs it out of its spatial-hash family; tried, it
  // changed the random strokes' minimum angle from 0.77 to 0.62 deg: not kept.)
  bool freeable(std::uint32_t region) const;
  void releaseLast(CutTopology& topology, const std::vector<std::uint32_t>& ring, const std::vector<Tet>& made);

  // Per-call scratch (kept between events: no allocation once grown).
  std::vector<std::uint8_t> listed_;       // by slot: in the change set's addedTets
  std::vector<std::uint32_t> queue_, written_, ring_;
  std::vector<Tet> best_;
  FlipChangeSet* change_ = nullptr;
  CutTopology* topology_ = nullptr;
  std::size_t firstFlipSlot_ = 0;  // slots from here on were appended by this call
};

}  // namespace blobvk::cutting
