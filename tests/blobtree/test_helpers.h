// Small builders for BlobTree nodes used across the blobtree tests.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <utility>
#include <vector>

namespace blobvk::testing {

inline blobtree::Node point(glm::dvec3 c, double support = 1.0) {
  blobtree::Primitive p;
  p.type = blobtree::PrimitiveType::Point;
  p.a = c;
  p.support = support;
  return blobtree::Node{p, "", {}, {}};
}

inline blobtree::Node op(blobtree::OperatorType t, std::vector<blobtree::Node> children,
                         double power = 2.0) {
  blobtree::Operator o;
  o.type = t;
  o.power = power;
  return blobtree::Node{o, "", {}, std::move(children)};
}

inline blobtree::Node warp(blobtree::Warp w, blobtree::Node child) {
  return blobtree::Node{w, "", {}, {std::move(child)}};
}

}  // namespace blobvk::testing
