// Instancing shared by the JSON and legacy readers: an instance is a copy of another node placed
// with its own transform. Internal to the scene readers (not part of the public API).
#pragma once

#include "blobvk/blobtree/tree.h"

#include <cstddef>
#include <string>

namespace blobvk::blobtree::detail {

// The copy of `original` seen through `placement` (p_parent = placement(original(p_local))).
// The two transforms are folded into one when that is exact (uniform placement scale, or an
// unrotated original); otherwise the copy is wrapped in a one-child union that carries the
// placement, which leaves the field unchanged. The copy takes `id` when it is not empty.
Node instantiate(const Node& original, const Transform& placement, const std::string& id);

// Composition outer∘inner when it is an exact TRS transform; false when it is not.
bool composeTransforms(const Transform& outer, const Transform& inner, Transform& out);

bool isIdentityTransform(const Transform& t);

struct SubtreeSize {
  std::size_t nodes = 0;
  std::size_t height = 0;  // 1 for a leaf
  std::size_t idBytes = 0;  // the nodes' ids' characters
};
SubtreeSize measure(const Node& node);

}  // namespace blobvk::blobtree::detail
