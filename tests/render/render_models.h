// Small models with known geometry for the renderer tests.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <cmath>
#include <utility>
#include <vector>

namespace blobvk::testing {

// Kernel support that puts the iso surface (0.5) of a lone point primitive at `radius`:
// (1 - d^2)^3 = 1/2 at d = sqrt(1 - 2^(-1/3)).
inline double supportForRadius(double radius) { return radius / std::sqrt(1.0 - std::pow(0.5, 1.0 / 3.0)); }

inline blobtree::Node sphere(glm::dvec3 centre, double radius, glm::dvec3 colour = {0.8, 0.8, 0.8}) {
  blobtree::Primitive p;
  p.type = blobtree::PrimitiveType::Point;
  p.a = centre;
  p.support = supportForRadius(radius);
  p.colour = colour;
  return blobtree::Node{p, "", {}, {}};
}

inline blobtree::Node unionOf(std::vector<blobtree::Node> children) {
  blobtree::Operator o;
  o.type = blobtree::OperatorType::Union;
  return blobtree::Node{o, "", {}, std::move(children)};
}

}  // namespace blobvk::testing
