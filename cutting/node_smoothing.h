// Node smoothing at rest after a cut event's flips: a tet the event wrote that is still below the
// threshold gets its free nodes moved, one at a time, to where the smallest dihedral angle of the
// tets around the node is largest among a few candidates (towards the centroid of its star, and
// away from the face opposite it in the worst tet). Flips cannot reach a tet whose bad angle needs
// a node moved; this can, without adding or removing a tet.
// A node is free to move, all its tets in one region (each region keeps its volume: the union of
// the star is unchanged, only the node inside it moves), when
//   - it is interior (its link is one sphere) and on no cut surface, or interior and snapped to
//     one planar cut surface, its star undeformed (rest = current positions, where the cutter
//     took the plane): it slides parallel to that plane, so its distance to the cut (what the
//     cutter's later snap decisions about it read) is kept, or
//   - it is on the boundary (crack faces included) with a link that is one disk, and all the
//     boundary faces around it lie in one plane: it slides within that plane (a flat piece of the
//     surface or of a crack sheet), or in two planes (a crease: a crack sheet meeting another or
//     the surface): it slides along their line. The boundary, the crack and the volume are kept
//     (the star stays positive, so the boundary faces still tile the same pieces of their planes).
//   - it is the apex of a spike: in one tet only (its three faces on the boundary), all four of
//     whose nodes lie on cut surfaces (a piece between crack sheets the cuts left hanging off the
//     body). It slides parallel to the opposite face, so the tet's height and volume are kept,
//     towards the point over that face's incentre (the largest smallest angle a slide can give),
//     stopping at the first of 1/8, 1/4, 1/2 and all of the way that reaches the threshold. This
//     changes the surface: the spike's own three faces move (no other tet has the node), within
//     the slab of the spike's height over its base plane.
// Any other node where three planes meet, on a curved boundary or on a crack's rim stays. A move
// is taken only when every tet around the node stays positive at rest and in the current
// positions and the star's smallest angle rises.
// The FEM takes a move as a change of the rest shape of the node's tets (fem::TopologyChange::
// movedNodes): the node's new rest position is a barycentric combination of the tet that held it
// (for a spike's apex, which leaves its one tet, an affine one: some weights negative), so its
// position and velocity in a deformed body follow from the same weights.
// Deterministic: seeds in slot order, nodes in tet order.
#pragma once

#include "blobvk/cutting/local_flips.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/topology.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::cutting {

// A node moved at rest: its new rest position (and current position) is sum(weights[i] *
// value(sources[i])), the values as they were just before this move (sources: the nodes of the
// tet that contained the new rest position, the moved node possibly among them).
struct MovedNode {
  std::uint32_t index = 0;
  std::array<std::uint32_t, 4> sources{};
  std::array<double, 4> weights{};
};

class NodeSmoothing {
 public:
  // Tries the free nodes of the tets of `seeds` (sorted slots) below `belowDeg`. `onCut[n] > 0`
  // marks a node on a cut surface (the cutter's snap reach): on the boundary it moves only within
  // a flat fan or along a crease, or parallel to the base of a spike all of whose nodes are
  // marked; an interior one only parallel to `snapPlane[n]`, the unit
  // normal of the one cut plane it was snapped to (zero or NaN: it stays; shorter than onCut:
  // none known). Every tet around a moved node is appended to the change set (listed as removed with
  // its unchanged nodes when the event had not written it) and registered in the grid; each move
  // is appended to `moved`, in order. Returns the number of moves.
  std::size_t improve(CutTopology& topology, SpatialGrid& grid, std::span<const std::uint32_t> seeds, double belowDeg,
                      const std::vector<double>& onCut, const std::vector<mesh::Double3>& snapPlane,
                      FlipChangeSet change, std::vector<MovedNode>& moved);

 private:
  // `threshold`: the quality (dihedralQuality) the caller asks for; a spike stops short at it.
  bool tryNode(CutTopology& topology, std::uint32_t node, double threshold, const std::vector<double>& onCut,
               const std::vector<mesh::Double3>& snapPlane, MovedNode& move);

  std::vector<std::uint8_t> listed_;  // by slot: in the change set's addedTets
  std::vector<std::uint8_t> tried_;   // by node: tried in this call (a node is tried once)
  std::vector<std::uint32_t> triedNodes_;
  std::vector<std::uint32_t> star_;
  std::vector<std::uint64_t> linkEdges_;
  std::vector<std::uint32_t> linkNodes_;
  std::vector<std::uint64_t> boundaryEdges_;  // link edges of one tet: under a boundary face
  std::vector<std::uint32_t> rimNodes_;
  std::vector<std::uint8_t> leftBox_;  // by star position: the move took the node out of the tet's box
};

}  // namespace blobvk::cutting
