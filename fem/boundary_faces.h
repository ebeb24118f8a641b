// The boundary faces of a tet mesh (faces used by exactly one tet, oriented outward), kept up to
// date under local tet edits: after a change only the faces of the removed and added tets are
// re-examined. The list stays in the order of findBoundaryFaces (by sorted node triple), so an
// edited mesh matches a freshly built one, and it is edited in place: the caller's vector (the
// mesh's boundaryFaces) is the set's value, next to a parallel array of sorted keys.
#pragma once

#include "blobvk/fem/node_incidence.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

class BoundaryFaceSet {
 public:
  using Face = std::array<std::uint32_t, 3>;
  // Sorts `faces` into key order (dropping repeated faces) and keeps their keys.
  void build(std::vector<Face>& faces);

  using Tet = std::array<std::uint32_t, 4>;

  // Brings `faces` (the vector given to build, as edited by earlier updates) up to date after a
  // change. `removed`: the tets the change overwrote (their versions before it); `added`: the
  // tets it wrote; their faces are what is re-examined. `incidence` is the edited mesh's; nodes
  // at or past `firstNewNode` are new. When every slot was written once (`addedAreFinal`), a face's users
  // follow from counting: before (1 if listed; else 0 or, for a face a removed tet had, 2) minus
  // removed plus added. That holds for conforming meshes (a face has at most two tets), which
  // meshers and cuts produce; the few faces where it cannot decide (a new face between old
  // nodes, a face left to an untouched tet) and every face when slots repeat are re-counted
  // from the incidence rows. Cost: O(faces of the change), plus, when faces appear or vanish,
  // in-place moves of the list after the first edit (memmove of runs, no per-face work).
  void update(const std::vector<Tet>& removed, const std::vector<Tet>& added, bool addedAreFinal,
              std::uint32_t firstNewNode, const NodeIncidence& incidence, std::vector<Face>& faces);

 private:
  struct KeyState {
    Face key, oriented;  // oriented: as the (last) added tet using it has it
    std::uint32_t removedUses = 0, addedUses = 0;
    std::uint32_t slot = 0;  // where it sits in the hash table (to clear it afterwards)
  };
  struct Edit {
    Face key, oriented;
    bool insert;  // false: erase
  };
  // Dense list of the distinct keys of a change (a small open-addressing table indexes it).
  KeyState& state(const Face& key);
  void clearStates();
  void applyEdits(std::vector<Face>& faces);

  std::vector<Face> keys_;  // sorted keys of `faces`, index for index
  std::vector<KeyState> states_;
  std::vector<std::uint32_t> table_;  // 0 = empty, else 1 + index into states_
  std::vector<Edit> edits_;
  std::vector<std::size_t> positions_;  // of the erases, then of the inserts, in applyEdits
};

}  // namespace blobvk::fem
