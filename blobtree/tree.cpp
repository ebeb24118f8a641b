#include "blobvk/blobtree/tree.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace blobvk::blobtree {

bool Transform::isIdentity() const {
  return translate == Vec3(0.0) && scale == Vec3(1.0) && rotate == Quat(1.0, 0.0, 0.0, 0.0);
}

TreeStats treeStats(const Node& root) {
  // Iterative: scene trees may be deep (caterpillars), and a recursion per node would make the
  // stack depth the user's choice.
  TreeStats stats;
  std::vector<std::pair<const Node*, std::size_t>> todo{{&root, 1}};
  while (!todo.empty()) {
    const auto [node, depth] = todo.back();
    todo.pop_back();
    stats.depth = std::max(stats.depth, depth);
    if (node->isPrimitive()) ++stats.primitives;
    else if (node->isWarp()) ++stats.warps;
    else ++stats.operators;
    for (const Node& child : node->children) todo.emplace_back(&child, depth + 1);
  }
  return stats;
}

const char* toString(PrimitiveType t) {
  switch (t) {
    case PrimitiveType::Point: return "point";
    case PrimitiveType::Line: return "line";
    case PrimitiveType::Cylinder: return "cylinder";
    case PrimitiveType::Disc: return "disc";
    case PrimitiveType::Ring: return "ring";
    case PrimitiveType::Cube: return "cube";
    case PrimitiveType::Triangle: return "triangle";
    case PrimitiveType::QuadricPoint: return "quadricPoint";
  }
  return "?";
}

const char* toString(OperatorType t) {
  switch (t) {
    case OperatorType::Blend: return "blend";
    case OperatorType::Ricci: return "ricci";
    case OperatorType::Union: return "union";
    case OperatorType::Intersection: return "intersection";
    case OperatorType::Difference: return "difference";
    case OperatorType::SmoothDifference: return "smoothDifference";
  }
  return "?";
}

const char* toString(WarpType t) {
  switch (t) {
    case WarpType::Twist: return "twist";
    case WarpType::Taper: return "taper";
    case WarpType::Bend: return "bend";
    case WarpType::Shear: return "shear";
  }
  return "?";
}

}  // namespace blobvk::blobtree
