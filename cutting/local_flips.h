// Local improvement of the tets a cut event made (Klingner & Shewchuk 2007's topological
// operations, restricted to what a running FEM takes without deleting a tet slot it has): a tet
// whose smallest dihedral angle at rest is below a threshold is replaced, with a neighbour, by
// the best of
//   - face removal (2-3 flip): the tet and the tet across one of its interior faces become three
//     tets around the edge joining their apexes;
//   - edge removal (n -> 2n - 4, n = 3..7 tets around an interior edge): the ring of tets around
//     one of its edges becomes the cones from the edge's two ends over the best triangulation of
//     the ring's polygon (every triangulation tried). The 3-2 flip (n = 3) frees a slot: the
//     event's last slot, which the FEM has not seen yet, moves into it and is given back (so the
//     3-2 flip needs an event that appended a slot; every event that splits a tet does);
//   - boundary edge removal (n -> 2n - 2, n = 2..6 tets around an edge on the boundary, crack
//     faces included, whose two boundary faces lie in one plane): the open ring becomes the cones
//     from the edge's ends over a triangulation of its polygon closed by a new boundary edge, so
//     the two boundary faces of the flat quad swap their diagonal (n = 2: a 2-2 flip). This
//     reaches the bad angles at the edges of a flat piece of a crack or of the surface, where no
//     node may move (its nodes lie where three or more planes meet).
// An operation is taken when it raises the smallest dihedral angle of the tets it replaces, and
// only where every tet it touches has the same region, every new tet is positive at rest and in
// the current positions, and no new edge exists elsewhere. It keeps the nodes, the boundary as a
// surface (crack faces included: they are boundary faces once the crack is open; a boundary edge
// removal re-triangulates a flat quad of it within its plane), the parts and the union of the
// replaced tets, so the mesh stays conforming and its volume is kept to rounding.
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
  // threeTwo and boundaryEdgeRemovals: within edgeRemovals
  std::size_t faceRemovals = 0, edgeRemovals = 0, threeTwo = 0, boundaryEdgeRemovals = 0, attempts = 0;
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
  // event wrote (they are not listed as removed again). `eventFirstSlot`: the slot count before
  // the event (slots from there on are new to the FEM; a 3-2 flip may give the last one back).
  FlipStats improve(CutTopology& topology, SpatialGrid& grid, std::span<const std::uint32_t> seeds, double belowDeg,
                    std::size_t maxAttempts, std::size_t eventFirstSlot, FlipChangeSet change);

 private:
  // One attempt on the tet in `slot` when its smallest dihedral angle has a cosine above
  // belowCosine (the threshold's, computed once per call).
  bool improveTet(CutTopology& topology, std::uint32_t slot, double belowCosine, FlipStats& stats);
  void write(CutTopology& topology, std::uint32_t slot, const Tet& nodes);
  std::uint32_t append(CutTopology& topology, const Tet& nodes, std::uint32_t region);
  // A 3-2 flip frees a slot, which a running FEM cannot take: it is done only when the last slot
  // was appended in this event (and the mesh has no hole), and that slot is given back: its
  // content and region move into the freed ring slot, and it leaves the spatial hash's families
  // (SpatialGrid::release).
  bool freeable() const;
  void freeSlot(CutTopology& topology, const std::vector<std::uint32_t>& ring, const std::vector<Tet>& made);

  // Per-call scratch (kept between events: no allocation once grown).
  std::vector<std::uint8_t> listed_;       // by slot: in the change set's addedTets
  std::vector<std::uint32_t> queue_, written_, ring_;
  std::vector<Tet> best_;
  FlipChangeSet* change_ = nullptr;
  CutTopology* topology_ = nullptr;
  SpatialGrid* grid_ = nullptr;
  std::size_t eventFirstSlot_ = 0;  // slots from here on were appended in this event
};

}  // namespace blobvk::cutting
