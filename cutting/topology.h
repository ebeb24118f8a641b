// Mutable tetrahedral topology for cutting: nodes and tets with per-node tet lists, kept up to
// date incrementally as tets are split (thesis §6.1 VolMesh). Edges and faces are not stored:
// they are answered from the tet lists of their nodes (a node has ~20 tets), which made every
// tet insertion 4 list pushes instead of 10 hash-table updates, each a cache miss in a table of
// the mesh's size. Tet slots are reused; deleted tets leave holes until compact().
#pragma once

#include "blobvk/cutting/flat_hash.h"
#include "blobvk/cutting/incidence_lists.h"
#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::cutting {

inline constexpr std::uint32_t kNone = 0xffffffffu;
using Tet = std::array<std::uint32_t, 4>;
using Face = std::array<std::uint32_t, 3>;

// Outward faces of tet (0,1,2,3) in the thesis numbering f0..f3 (face i is opposite node i).
inline constexpr std::array<std::array<int, 3>, 4> kTetFaces = {{{1, 2, 3}, {2, 0, 3}, {3, 0, 1}, {1, 0, 2}}};
// Local edges in the thesis numbering e0..e5 (so cut-edge codes 56/37/11/22, 46/51/29 match).
inline constexpr std::array<std::array<int, 2>, 6> kTetEdges = {{{1, 2}, {2, 3}, {3, 1}, {2, 0}, {0, 3}, {0, 1}}};

inline std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(a) << 32) | b;
}

struct FaceKey {
  std::uint32_t a, b, c;  // sorted ascending
  friend bool operator==(const FaceKey&, const FaceKey&) = default;
};
FaceKey makeFaceKey(std::uint32_t a, std::uint32_t b, std::uint32_t c);
struct FaceKeyHash {
  std::uint64_t operator()(const FaceKey& k) const {
    return mix64(((std::uint64_t(k.a) << 32) | k.b) ^ mix64(std::uint64_t(k.c) + 0x9E3779B97F4A7C15ull));
  }
};
inline constexpr FaceKey kNoFace{kNone, kNone, kNone};
inline constexpr std::uint64_t kNoEdge = ~0ull;  // edgeKey(kNone, kNone): never a real edge

struct SelfCheckReport {
  std::size_t tets = 0, nodes = 0, interiorFaces = 0, boundaryFaces = 0;
  std::size_t overSharedFaces = 0;      // faces used by 3+ tets (non-conforming)
  std::size_t misorientedFaces = 0;     // interior face traversed the same way by both tets
  std::size_t duplicateTets = 0;        // same node set twice
  std::size_t nonPositiveTets = 0;      // rest volume <= 0
  std::size_t degenerateTets = 0;       // repeated or out-of-range node index
  std::size_t incidenceMismatches = 0;  // incremental tet lists disagree with a rebuild
  bool ok() const {
    return overSharedFaces == 0 && misorientedFaces == 0 && duplicateTets == 0 && nonPositiveTets == 0 &&
           degenerateTets == 0 && incidenceMismatches == 0;
  }
  std::string summary() const;
};

class CutTopology {
 public:
  explicit CutTopology(mesh::TetMesh mesh);

  // The mesh; tets of dead slots hold stale data until compact(). boundaryFaces is only
  // refreshed by toTetMesh().
  const mesh::TetMesh& mesh() const { return mesh_; }
  // Current positions may be updated by the simulation (same size; rest positions untouched).
  std::vector<mesh::Double3>& positions() { return mesh_.positions; }

  std::size_t slotCount() const { return mesh_.tets.size(); }
  std::size_t liveTetCount() const { return mesh_.tets.size() - freeSlots_.size(); }
  bool alive(std::uint32_t slot) const { return alive_[slot] != 0; }
  const Tet& tet(std::uint32_t slot) const { return mesh_.tets[slot]; }

  std::uint32_t addNode(mesh::Double3 position, mesh::Double3 rest);
  // Moves a node (position and rest position); its tets keep their nodes.
  void moveNode(std::uint32_t node, mesh::Double3 position, mesh::Double3 rest) {
    mesh_.positions[node] = position;
    mesh_.restPositions[node] = rest;
  }
  // Inserts a tet in a free slot (lowest freed first is not guaranteed) or at the end.
  std::uint32_t addTet(const Tet& nodes, std::uint32_t region = 0);
  // Replaces the content of a live slot in place.
  void setTet(std::uint32_t slot, const Tet& nodes);
  // Deferred deletion: the slot is detached from all incidence and becomes a hole.
  void removeTet(std::uint32_t slot);
  // Fills holes with tets from the end; returns (from, to) slot moves. Nodes are never removed.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> compact();

  // Incidence queries, O(node degree). The span is invalidated by the next change to the mesh.
  std::span<const std::uint32_t> tetsOfNode(std::uint32_t node) const { return tetsOfNode_.of(node); }
  bool hasEdge(std::uint32_t a, std::uint32_t b) const;
  // The (up to two) tets sharing the face, kNone where absent (the first two found when a
  // non-conforming face has more; selfCheck reports those).
  std::array<std::uint32_t, 2> tetsOfFace(std::uint32_t a, std::uint32_t b, std::uint32_t c) const;

  // Full O(n) verification against a from-scratch rebuild.
  SelfCheckReport selfCheck() const;
  // Compacted copy with boundary faces (outward) recomputed.
  mesh::TetMesh toTetMesh() const;
  double totalRestVolume() const;

 private:
  void attach(std::uint32_t slot);
  void detach(std::uint32_t slot);
  void retarget(std::uint32_t slot, const Tet& before, const Tet& after);

  mesh::TetMesh mesh_;
  std::vector<std::uint8_t> alive_;
  std::vector<std::uint32_t> freeSlots_;
  IncidenceLists tetsOfNode_;
};

}  // namespace blobvk::cutting
