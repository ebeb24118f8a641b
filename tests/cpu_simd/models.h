// BlobTree models for the cpu_simd tests and benchmarks: one of every node type (primitives
// under rotations and non-uniform scales, every operator, every warp) plus the thesis scenes from
// blobtree/generators.h and the early-discard traps (tiny primitives, thin shells, grazing).
#pragma once

#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/tree.h"

#include <glm/gtc/quaternion.hpp>

#include <string>
#include <utility>
#include <vector>

namespace blobvk::testmodels {

using blobtree::Node;
using blobtree::OperatorType;
using blobtree::PrimitiveType;
using blobtree::WarpType;

inline Node primitive(PrimitiveType type, glm::dvec3 a, glm::dvec3 b = {0, 1, 0},
                      double radius = 0.5, double height = 1.0, double support = 1.0) {
  blobtree::Primitive p;
  p.type = type;
  p.a = a, p.b = b, p.radius = radius, p.height = height, p.support = support;
  p.colour = {0.2 + 0.1 * double(type), 0.9 - 0.1 * double(type), 0.5};
  return Node{p, "", {}, {}};
}

inline Node op(OperatorType t, std::vector<Node> children, double power = 2.0) {
  blobtree::Operator o;
  o.type = t, o.power = power;
  return Node{o, "", {}, std::move(children)};
}

inline Node warp(WarpType t, double factor, int axis, int other, Node child, double centre = 0.0,
                 double lo = -1e30, double hi = 1e30) {
  blobtree::Warp w;
  w.type = t, w.factor = factor, w.axis = axis, w.otherAxis = other, w.centre = centre;
  w.lo = lo, w.hi = hi;
  return Node{w, "", {}, {std::move(child)}};
}

inline Node transformed(Node n, glm::dvec3 translate, glm::dquat rotate, glm::dvec3 scale) {
  n.transform.translate = translate, n.transform.rotate = rotate, n.transform.scale = scale;
  return n;
}

// One primitive of `type`, moved, rotated and scaled non-uniformly.
inline Node onePrimitive(PrimitiveType type) {
  Node p;
  switch (type) {
    case PrimitiveType::Line: p = primitive(type, {-0.5, 0, 0}, {0.6, 0.3, 0.1}, 0, 0, 0.8); break;
    case PrimitiveType::Cylinder: p = primitive(type, {0, -0.4, 0}, {0, 1, 0}, 0.4, 0.8, 0.7); break;
    case PrimitiveType::Disc: p = primitive(type, {0, 0, 0}, {0.3, 1, 0.2}, 0.7, 0, 0.6); break;
    case PrimitiveType::Ring: p = primitive(type, {0, 0, 0}, {0, 0.2, 1}, 0.8, 0, 0.5); break;
    case PrimitiveType::Cube: p = primitive(type, {0, 0, 0}, {0.4, 0.3, 0.5}, 0, 0, 0.6); break;
    case PrimitiveType::Triangle: {
      p = primitive(type, {-0.6, -0.4, 0}, {0.7, -0.2, 0.1}, 0, 0, 0.6);
      std::get<blobtree::Primitive>(p.kind).c = {0.0, 0.8, -0.2};
      break;
    }
    case PrimitiveType::QuadricPoint: {
      p = primitive(type, {0, 0, 0}, {}, 0, 0, 1.1);
      std::get<blobtree::Primitive>(p.kind).scale = 1.3;
      break;
    }
    default: p = primitive(type, {0.1, 0, 0}, {}, 0, 0, 1.0); break;
  }
  return transformed(std::move(p), {0.2, -0.1, 0.3}, glm::angleAxis(0.6, glm::normalize(glm::dvec3(1, 2, 3))),
                     {1.2, 0.8, 1.1});
}

inline std::vector<std::pair<std::string, Node>> primitiveModels() {
  std::vector<std::pair<std::string, Node>> out;
  const char* names[] = {"point", "line", "cylinder", "disc", "ring", "cube", "triangle", "quadric"};
  for (int t = 0; t < 8; ++t) out.emplace_back(names[t], onePrimitive(PrimitiveType(t)));
  return out;
}

inline std::vector<Node> pair() {
  return {primitive(PrimitiveType::Point, {-0.35, 0, 0}, {}, 0, 0, 1.0),
          primitive(PrimitiveType::Cylinder, {0.3, -0.6, 0.1}, {0, 1, 0}, 0.3, 1.2, 0.8)};
}

inline std::vector<std::pair<std::string, Node>> operatorModels() {
  std::vector<std::pair<std::string, Node>> out;
  out.emplace_back("blend", op(OperatorType::Blend, pair()));
  out.emplace_back("ricci", op(OperatorType::Ricci, pair(), 3.0));
  // A power whose children's powers fall below the smallest normal float near the surface (0.5^200
  // is 6e-61): OP_POW flushes them to 0 (blobtree/pow_field.h), and the bounds must hold that.
  out.emplace_back("ricci_p200", op(OperatorType::Ricci, pair(), 200.0));
  out.emplace_back("union", op(OperatorType::Union, pair()));
  out.emplace_back("intersection", op(OperatorType::Intersection, pair()));
  out.emplace_back("difference", op(OperatorType::Difference, pair()));
  out.emplace_back("smooth_difference", op(OperatorType::SmoothDifference, pair()));
  // A cutter that is itself a subtree (compile() may reorder it) and nested operators.
  out.emplace_back("nested_difference",
                   op(OperatorType::Difference,
                      {primitive(PrimitiveType::Point, {0, 0, 0}, {}, 0, 0, 1.3),
                       op(OperatorType::Blend, {primitive(PrimitiveType::Point, {0.5, 0.4, 0}),
                                                primitive(PrimitiveType::Point, {0.5, -0.4, 0}),
                                                primitive(PrimitiveType::Point, {0.6, 0, 0.3})})}));
  return out;
}

inline Node bar() {
  return op(OperatorType::Blend, {primitive(PrimitiveType::Line, {0, -1.2, 0}, {0, 1.2, 0}, 0, 0, 0.6),
                                  primitive(PrimitiveType::Cube, {0.3, 0, 0}, {0.2, 0.9, 0.2}, 0, 0, 0.5)});
}

inline std::vector<std::pair<std::string, Node>> warpModels() {
  std::vector<std::pair<std::string, Node>> out;
  out.emplace_back("twist", warp(WarpType::Twist, 1.2, 1, 0, bar()));
  out.emplace_back("taper", warp(WarpType::Taper, 0.3, 1, 0, bar()));
  out.emplace_back("bend", warp(WarpType::Bend, 0.5, 1, 0, bar(), 0.0, -0.8, 0.8));
  out.emplace_back("shear", warp(WarpType::Shear, 0.4, 0, 1, bar()));
  out.emplace_back("nested_warps",
                   warp(WarpType::Twist, 0.7, 2, 0, warp(WarpType::Shear, 0.3, 0, 2, bar())));
  return out;
}

inline Node tower() { return blobtree::generateTower(4, 8, 2.0, 2.0, 1); }
inline Node randomBlobs(int n = 128) { return blobtree::generateRandomBlobs(n, 1234); }

// Traps for an early discard: primitives much smaller than an MPU (the 8-corner test misses
// them), a thin shell, and a small blob whose surface grazes an MPU corner.
inline Node tinyPrimitives() {
  std::vector<Node> kids;
  for (int i = 0; i < 6; ++i)
    kids.push_back(primitive(PrimitiveType::Point, {0.53 * i - 1.3, 0.17 * i, 0.07 * i}, {}, 0, 0,
                             0.2 + 0.02 * i));
  kids.push_back(op(OperatorType::Blend, {primitive(PrimitiveType::Point, {2, 2, 2})}));
  return op(OperatorType::Union, std::move(kids));
}

inline Node thinShell() {
  return op(OperatorType::Difference,
            {primitive(PrimitiveType::Point, {0, 0, 0}, {}, 0, 0, 2.0),
             primitive(PrimitiveType::Point, {0, 0, 0}, {}, 0, 0, 1.96)});
}

}  // namespace blobvk::testmodels
