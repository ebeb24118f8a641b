// BoundaryFaceSet::update against findBoundaryFaces on the edited mesh: many scattered tets
// removed at once, then put back, so that one update erases and inserts faces all along the
// sorted list (runs of every length, several inserts at one position), in place.
#include "blobvk/fem/boundary_faces.h"
#include "blobvk/fem/node_incidence.h"
#include "blobvk/fem/tet_utils.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

namespace blobvk::fem {
namespace {

using Tet = BoundaryFaceSet::Tet;

NodeIncidence incidenceOf(const mesh::TetMesh& m) {
  NodeIncidence incidence;
  incidence.build(m.nodeCount(), m.tets);
  return incidence;
}

class ScatteredEdits : public ::testing::TestWithParam<bool> {};

TEST_P(ScatteredEdits, RemovingAndRestoringTetsMatchesAFreshList) {
  const bool addedAreFinal = GetParam();
  const mesh::TetMesh full = test::boxMesh(0.4, 0.3, 0.3, 0.05);
  std::vector<BoundaryFaceSet::Face> faces = findBoundaryFaces(full);
  BoundaryFaceSet set;
  set.build(faces);
  ASSERT_EQ(faces, findBoundaryFaces(full));

  // Every 7th tet (interior and boundary ones, spread over the node numbering) goes.
  mesh::TetMesh holed = full;
  holed.tets.clear();
  std::vector<Tet> removed;
  for (std::size_t t = 0; t < full.tets.size(); ++t) (t % 7 == 3 ? removed : holed.tets).push_back(full.tets[t]);
  const auto holedFaces = findBoundaryFaces(holed);
  ASSERT_GT(holedFaces.size(), faces.size() + removed.size());  // many faces appear
  set.update(removed, {}, addedAreFinal, std::uint32_t(full.nodeCount()), incidenceOf(holed), faces);
  EXPECT_EQ(faces, holedFaces);

  // Put back: the faces that appeared vanish and the old boundary faces come back, oriented.
  holed.tets.insert(holed.tets.end(), removed.begin(), removed.end());
  set.update({}, removed, addedAreFinal, std::uint32_t(full.nodeCount()), incidenceOf(holed), faces);
  EXPECT_EQ(faces, findBoundaryFaces(full));
}

INSTANTIATE_TEST_SUITE_P(BoundaryFaceSet, ScatteredEdits, ::testing::Bool());

}  // namespace
}  // namespace blobvk::fem
