// The boundary faces of a tet mesh (faces used by exactly one tet, oriented outward), kept up to
// date under local tet edits: after a change only the faces of the removed and added tets are
// re-examined, through the node incidence rows. The list comes out in the order of
// findBoundaryFaces (by sorted node triple), so an edited mesh matches a freshly built one.
#pragma once

#include "fem/node_incidence.h"

#include <array>
#include <cstdint>
#include <map>
#include <vector>

namespace blobvk::fem {

class BoundaryFaceSet {
 public:
  using Face = std::array<std::uint32_t, 3>;
  void build(const std::vector<Face>& faces);
  // Faces of `tet` (as key triples) to re-examine after the edit.
  static void collectFaces(const std::array<std::uint32_t, 4>& tet, std::vector<Face>& keys);
  // Re-examines the faces of the removed and of the added tets against the edited tets and
  // incidence: a face two added tets share is interior; the others cost a row scan each.
  void update(std::vector<Face> removed, std::vector<Face> added, const std::vector<std::array<std::uint32_t, 4>>& tets,
              const NodeIncidence& incidence);
  std::vector<Face> faces() const;  // O(boundary size)

 private:
  std::map<Face, Face> faces_;  // sorted key -> outward-oriented face
};

}  // namespace blobvk::fem
