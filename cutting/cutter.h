// One cut event (thesis §6.3-6.7, all cases): find the mesh edges the swept surface crosses,
// snap nearby nodes (cut nodes) and drop their edges, split every touched tet with the
// decomposition of decompose.h, then open the crack by duplicating the crack's nodes wherever the
// tets around them fall apart. Produces a CutResult change set for an incremental FEM rebuild.
#pragma once

#include "blobvk/cutting/blade.h"
#include "blobvk/cutting/decompose.h"
#include "blobvk/cutting/local_flips.h"
#include "blobvk/cutting/node_smoothing.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/topology.h"

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::cutting {

struct CutOptions {
  // tau: a crossing closer than tau * edge length to an edge end makes that end a cut node and
  // removes all its edges from the cut list (the thesis' roi was 0.2). Every kept cut point then
  // lies in [tau, 1 - tau] along its edge, which bounds the children's volumes from below (see
  // minimumChildVolumeFraction). Must lie in [0, 0.5). 0.42: after 100 random strokes through a
  // 100k-tet ball no dihedral angle is below 5 deg (0.28 deg with 0.2, docs/cutting.md), at the
  // price of a crack up to 0.42 edge lengths from the blade.
  double snapFraction = 0.42;
  // Nodes closer than this to the swept surface (relative to the mean edge length) are on it.
  double onSurfaceTolerance = 1e-9;
  // Partial cuts split around a Steiner point placed on the swept surface when all its
  // barycentric weights are >= this (else at the centroid); bounds those children's volumes.
  double steinerMargin = 0.1;
  // After the crack opens, tets the event wrote whose smallest dihedral angle at rest is below
  // this (degrees) are improved by flips (local_flips.h); 0: no flips.
  double improveBelowDeg = 15.0;
  // After the flips, the nodes of the tets the event wrote that are still below this (degrees)
  // are moved at rest where they are free to (interior nodes on no cut surface, or parallel to
  // the one cut plane they were snapped to; boundary and crack nodes within a flat fan of
  // boundary faces, or along a crease of two planes;
  // node_smoothing.h); the FEM takes the moves as rest-shape changes (CutResult::movedNodes).
  // With 15 deg seeds 1-16 of the 100 random strokes through the 100k-tet ball all end at or
  // above 5 deg (docs/cutting.md "Quality after cuts"). 0: none.
  double smoothBelowDeg = 15.0;
  // A quad crack (4 cut edges) is split into two triangles along the diagonal of the key rule
  // (decompose.h); when that leaves a child whose smallest dihedral angle at rest is below this
  // (degrees), the other diagonal is taken if its worst child is better. 0: the key rule alone.
  double crackDiagonalBelowDeg = 15.0;
};

struct NewNode {
  enum class Kind : std::uint8_t { EdgePoint, Steiner, Duplicate };
  std::uint32_t index = 0;
  Kind kind = Kind::EdgePoint;
  // position = sum(weights[i] * positions[sources[i]]) (same for rest positions); unused sources
  // are kNone. EdgePoint: 2 sources; Steiner: the 4 nodes of the split tet; Duplicate: 1 source
  // (the node it was split from; the two now belong to different sides of the crack). A source
  // is either an existing node or a node created earlier in the same event (a Duplicate of a
  // cut point or Steiner point), so appending newNodes in order always finds its sources.
  std::array<std::uint32_t, 4> sources{kNone, kNone, kNone, kNone};
  std::array<double, 4> weights{};
};

// Change set of one cut event. Tet slots are reused, so indices are valid before and after.
// For the FEM: drop the element formerly at each removedTets[i] (its nodes are removedTetNodes[i]),
// add the element now at each addedTets slot, grow the node arrays by newNodes (appended in
// order, positions and rest positions already set in the mesh). Slots in neither list are
// untouched; node indices never change.
struct CutResult {
  std::vector<std::uint32_t> removedTets;
  std::vector<Tet> removedTetNodes;
  std::vector<std::uint32_t> addedTets;
  std::vector<NewNode> newNodes;
  // Nodes moved at rest after the flips, in order (after newNodes; see MovedNode). Every tet
  // around a moved node is in addedTets.
  std::vector<MovedNode> movedNodes;
  std::array<std::size_t, 11> caseCounts{};  // indexed by CutCase
  std::size_t candidateTets = 0, cutEdges = 0, cutNodes = 0, splitTets = 0, separatingFallbacks = 0;
  std::size_t crackFaces = 0, duplicatedNodes = 0;
  // Thin pieces between two crack sheets kept attached instead of cut off (crack_slivers.h).
  std::size_t attachedSlivers = 0;
  // Flips after the opening (local_flips.h): face removals (2-3) and edge removals (n -> 2n-4).
  std::size_t faceRemovals = 0, edgeRemovals = 0;
  std::size_t flipAttempts = 0;  // written tets below the threshold that a flip was searched for
  double minChildVolumeRatio = 1.0;  // smallest child rest volume / its parent's, this event
  double seconds = 0.0;
  // Wall time of the phases: candidates (spatial hash), cut edges and cut nodes, codes + splits
  // + crack faces, crack opening.
  std::array<double, 4> phaseSeconds{};
  double flipSeconds = 0.0;  // the flips after the opening (included in seconds)
  std::size_t count(CutCase c) const { return caseCounts[std::size_t(c)]; }
};

class Cutter {
 public:
  explicit Cutter(mesh::TetMesh mesh, CutOptions options = {});

  // Cuts along the given swept triangles (a blade step, or a whole stroke at once).
  CutResult cut(const std::vector<Triangle>& swept);

  const CutTopology& topology() const { return topology_; }
  CutTopology& topology() { return topology_; }
  // Call after the simulation moved the nodes: rebuilds the spatial hash (O(n)).
  void positionsChanged() { grid_.rebuild(topology_); }
  const CutOptions& options() const { return options_; }

 private:
  CutTopology topology_;
  CutOptions options_;
  SpatialGrid grid_;
  DecompositionCache decompositions_;
  LocalFlips flips_;
  NodeSmoothing smoothing_;
  double meanEdge_ = 1.0;
  // By node: how far from a swept surface the node was when the crack was snapped to it (0: never
  // snapped). A snapped node stays a cut node for every later surface passing as close: without
  // this memory a later event could cross one of its edges beyond tau (the node's edges change as
  // its tets split) and put a second crack beside the first, cutting the sliver between them off
  // as a chip. Grown with the nodes; a duplicate inherits its source's reach.
  std::vector<double> snapReach_;
  // By node with snapReach_ > 0: the unit normal of the swept triangle it was snapped to, NaN
  // when it was snapped to two surfaces that are not parallel (kSnapPlaneSine). Node smoothing
  // lets an interior snapped node slide parallel to that plane: its distance to the cut surface,
  // and so every later snap decision about it (snapReach_), stays what it was.
  std::vector<mesh::Double3> snapPlane_;
  static constexpr double kSnapPlaneSine = 1e-10;
  void recordSnapPlane(std::uint32_t node, mesh::Double3 normal);
  // Per-event buffers reused across events (defined in cutter.cpp); makes Cutter move-only.
  struct Scratch;
  struct ScratchDeleter {
    void operator()(Scratch* scratch) const;
  };
  std::unique_ptr<Scratch, ScratchDeleter> scratch_;
};

// The smallest child/parent volume ratio any split can produce when every cut point lies in
// [tau, 1 - tau] along its edge: the children's barycentric determinants are multi-affine in the
// cut parameters, so the minimum over the parameter box is attained at a corner; this enumerates
// every cut code, every vertex-key order and every corner. Steiner children are scaled by the
// smallest allowed Steiner weight (CutOptions::steinerMargin).
double minimumChildVolumeFraction(double tau, double steinerMargin);

}  // namespace blobvk::cutting
