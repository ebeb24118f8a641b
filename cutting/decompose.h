// Sub-element generation for one cut tet (thesis §6.5-6.6), derived programmatically instead of
// typed tables. Local vertex ids: 0-3 the tet's nodes, 4+e the cut point on local edge e (thesis
// edge numbering, kTetEdges), 10 a Steiner point at the centroid. Every decision depends only on
// the cut masks and on the global ids ("keys") of the vertices, so two tets sharing a face always
// split it the same way: each face is cut along its cut segments into sub-polygons, and every
// polygon is fanned from its smallest-key vertex (the rule of Dompierre et al. 1999 that makes
// prisms and pyramids split without Steiner points).
#pragma once

#include "blobvk/cutting/flat_hash.h"

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

namespace blobvk::cutting {

enum class CutCase : std::uint8_t {
  Untouched,  // no cut edge, no cut node
  A,          // complete: 3 cut edges around one node (codes 56, 37, 11, 22)
  B,          // complete: 4 cut edges, quad slice (codes 46, 51, 29)
  C,          // partial: 1 cut edge
  D,          // partial: 2 cut edges
  E,          // partial: 3 cut edges not around one node
  X,          // complete: 1 cut node + 2 cut edges
  Y,          // complete: 2 cut nodes + 1 cut edge
  Z,          // 3 cut nodes: the crack runs along an existing face
  NodesOnly,  // 1-2 cut nodes and no cut edge: nothing to split
  Partial,    // any other non-separating combination (e.g. 4+ edges, node + 1 edge)
};
std::string_view cutCaseName(CutCase c);

inline constexpr int kEdgePointBase = 4;
inline constexpr int kSteinerLocal = 10;
inline constexpr int kMaxSubTets = 16;

struct Decomposition {
  CutCase kind = CutCase::Untouched;
  bool separating = false;  // the crack crosses the whole tet (A, B, X, Y)
  bool usesSteiner = false;
  int tetCount = 0;
  std::array<std::array<std::uint8_t, 4>, kMaxSubTets> tets{};  // positive orientation
  int crackCount = 0;
  std::array<std::array<std::uint8_t, 3>, 2> crack{};  // crack triangles (separating only)
};

// edgeMask: bit e = local edge e is cut; nodeMask: bit i = node i is a cut node (no cut edge may
// touch a cut node: the filtering guarantees it). keys: global ids of the 11 local vertices
// (unused entries ignored); cut points must have keys larger than every node key.
// forcePartial: split conformingly around a Steiner point without opening the crack (the
// fallback when the separating split would create a non-positive tet).
Decomposition decomposeTet(std::uint8_t edgeMask, std::uint8_t nodeMask, const std::array<std::uint64_t, 11>& keys,
                           bool forcePartial = false);

// Memo of decomposeTet for a cutter's lifetime. The result depends only on the masks and on the
// relative order of the keys (fans and cones pick smallest keys), so the order pattern (each
// key's rank among the 11) is the memo key: a few hundred patterns cover a whole cutting session,
// and a hit costs ~150 instructions instead of ~18,000 for the derivation. The reference is valid
// until the next get().
class DecompositionCache {
 public:
  const Decomposition& get(std::uint8_t edgeMask, std::uint8_t nodeMask, const std::array<std::uint64_t, 11>& keys,
                    bool forcePartial = false);
  std::size_t size() const { return entries_.size(); }

 private:
  FlatHashMap<std::uint64_t, std::uint32_t, U64Hash> index_{~0ull};
  std::vector<Decomposition> entries_;
};

CutCase classifyCut(std::uint8_t edgeMask, std::uint8_t nodeMask);

// Thesis code helpers: the cut-edge code of "node n separated" (case A) and of the quad slices.
std::uint8_t caseAEdgeCode(int node);

}  // namespace blobvk::cutting
