// A tree-walking evaluator in double precision, straight from the BlobTree with no compilation:
// the independent oracle that proves compile() preserves the field. Test-only.
#pragma once

#include "blobvk/blobtree/tree.h"

namespace blobvk::testing {

double treeWalkField(const blobtree::Node& node, const glm::dvec3& p);

}  // namespace blobvk::testing
