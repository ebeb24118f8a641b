// Slivers between two crack sheets. Snapping puts the crack through a node up to tau x edge
// from the blade; when a later event's surface (another blade interval, bent by the body's
// motion) crosses the same tets beside that node, the crack runs twice, once through the node
// and once along the surface, and the thin layer between the two sheets falls out as a 1-24-tet
// chip. Before the crack opens, this finds the small face-connected pieces the event's crack
// faces would enclose and keeps each one attached to the body by un-cracking one of its faces,
// when every node of the piece lies on a cut surface (a cut point or a snapped node): such a
// piece has no material beyond the snap zone, so it is a by-product of snapping, not a piece
// the blade cut off.
#pragma once

#include "blobvk/cutting/topology.h"

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::cutting {

class CrackSlivers {
 public:
  // Pieces of at most this many tets are candidates.
  static constexpr std::size_t kMaxPieceTets = 64;

  // `crack`: this event's crack faces, sorted by (a, b, c) and unique; faces that keep a sliver
  // attached are removed from it. `onCut[node] > 0`: the node lies on a cut surface (nodes past
  // its end do not). Returns the number of slivers kept attached.
  std::size_t attach(const CutTopology& topology, std::vector<FaceKey>& crack, std::span<const double> onCut);

 private:
  // Collects the piece of `seed` (tets joined by faces shared by two tets and not on the crack)
  // into piece_; true for a sliver. The search stops, false, at a tet with a node off the cut
  // surfaces, past kMaxPieceTets, or at a tet of a piece already found not to be a sliver: most
  // tets along a crack have a node off it, so most searches end at their seed.
  bool explore(const CutTopology& topology, const std::vector<FaceKey>& crack, std::span<const double> onCut,
               std::uint32_t seed);

  std::vector<std::uint8_t> state_;  // by slot: 0 unseen, 1 in a sliver, 2 in a piece that is not one
  std::vector<std::uint32_t> seen_, piece_;
  std::vector<FaceKey> uncrack_;
};

}  // namespace blobvk::cutting
