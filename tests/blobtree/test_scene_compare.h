// Structural comparison of BlobTrees for the scene I/O tests: every field that a reader or writer
// could lose, compared with a tolerance for the doubles.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace blobvk::testing {

inline bool nearlyEqual(double a, double b, double tol) {
  return a == b || std::abs(a - b) <= tol * std::max(1.0, std::max(std::abs(a), std::abs(b)));
}

inline bool nearlyEqual(const glm::dvec3& a, const glm::dvec3& b, double tol) {
  return nearlyEqual(a.x, b.x, tol) && nearlyEqual(a.y, b.y, tol) && nearlyEqual(a.z, b.z, tol);
}

// Rotations q and -q are the same.
inline bool sameRotation(const glm::dquat& a, const glm::dquat& b, double tol) {
  return std::abs(std::abs(glm::dot(a, b)) - 1.0) <= tol;
}

// Adds a gtest failure naming the path of the first difference; returns whether equal.
inline bool expectSameTree(const blobtree::Node& a, const blobtree::Node& b, double tol = 1e-12,
                           const std::string& path = "root") {
  using namespace blobtree;
  auto differ = [&](const std::string& what) {
    ADD_FAILURE() << "trees differ at " << path << ": " << what;
    return false;
  };
  if (a.id != b.id) return differ("id '" + a.id + "' vs '" + b.id + "'");
  if (a.kind.index() != b.kind.index()) return differ("node kind");
  if (!nearlyEqual(a.transform.translate, b.transform.translate, tol)) return differ("translate");
  if (!nearlyEqual(a.transform.scale, b.transform.scale, tol)) return differ("scale");
  if (!sameRotation(a.transform.rotate, b.transform.rotate, tol)) return differ("rotate");
  if (const auto* pa = std::get_if<Primitive>(&a.kind)) {
    const auto& pb = std::get<Primitive>(b.kind);
    if (pa->type != pb.type) return differ("primitive type");
    // Only the parameters the type uses (docs/scene-format.md); the others are not stored.
    const PrimitiveType t = pa->type;
    const bool usesB = t != PrimitiveType::Point && t != PrimitiveType::QuadricPoint;
    const bool usesRadius = t == PrimitiveType::Cylinder || t == PrimitiveType::Disc || t == PrimitiveType::Ring;
    if (!nearlyEqual(pa->a, pb.a, tol)) return differ("primitive point a");
    if (usesB && !nearlyEqual(pa->b, pb.b, tol)) return differ("primitive point b");
    if (t == PrimitiveType::Triangle && !nearlyEqual(pa->c, pb.c, tol)) return differ("primitive point c");
    if (usesRadius && !nearlyEqual(pa->radius, pb.radius, tol)) return differ("radius");
    if (t == PrimitiveType::Cylinder && !nearlyEqual(pa->height, pb.height, tol)) return differ("height");
    if (t == PrimitiveType::QuadricPoint && !nearlyEqual(pa->scale, pb.scale, tol)) return differ("scale S");
    if (!nearlyEqual(pa->support, pb.support, tol)) return differ("support");
    if (!nearlyEqual(pa->colour, pb.colour, tol)) return differ("colour");
  } else if (const auto* oa = std::get_if<Operator>(&a.kind)) {
    const auto& ob = std::get<Operator>(b.kind);
    if (oa->type != ob.type) return differ("operator type");
    if (oa->type == OperatorType::Ricci && !nearlyEqual(oa->power, ob.power, tol)) return differ("power");
  } else {
    const auto& wa = std::get<Warp>(a.kind);
    const auto& wb = std::get<Warp>(b.kind);
    if (wa.type != wb.type || wa.axis != wb.axis) return differ("warp type or axis");
    if (wa.type != WarpType::Twist && wa.otherAxis != wb.otherAxis) return differ("warp other axis");
    if (!nearlyEqual(wa.factor, wb.factor, tol) || !nearlyEqual(wa.centre, wb.centre, tol) ||
        !nearlyEqual(wa.lo, wb.lo, tol) || !nearlyEqual(wa.hi, wb.hi, tol))
      return differ("warp parameters");
  }
  if (a.children.size() != b.children.size())
    return differ("child count " + std::to_string(a.children.size()) + " vs " + std::to_string(b.children.size()));
  for (std::size_t i = 0; i < a.children.size(); ++i)
    if (!expectSameTree(a.children[i], b.children[i], tol, path + "/" + std::to_string(i))) return false;
  return true;
}

struct NodeCounts {
  std::size_t primitives = 0, operators = 0, warps = 0;
};

inline void countNodes(const blobtree::Node& n, NodeCounts& c) {
  if (n.isPrimitive()) ++c.primitives;
  else if (n.isOperator()) ++c.operators;
  else ++c.warps;
  for (const auto& child : n.children) countNodes(child, c);
}

inline NodeCounts countNodes(const blobtree::Node& n) {
  NodeCounts c;
  countNodes(n, c);
  return c;
}

}  // namespace blobvk::testing
