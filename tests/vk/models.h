// Small test models covering every primitive, operator and warp type.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <string>
#include <utility>
#include <vector>

namespace blobvk::testing {

inline blobtree::Node prim(blobtree::PrimitiveType type, glm::dvec3 a, glm::dvec3 b = {},
                           double radius = 0.0, double height = 0.0) {
  blobtree::Primitive p;
  p.type = type;
  p.a = a;
  p.b = b;
  p.radius = radius;
  p.height = height;
  return blobtree::Node{p, "", {}, {}};
}

inline blobtree::Node pointAt(glm::dvec3 c, glm::dvec3 colour = {0.8, 0.8, 0.8}) {
  auto n = prim(blobtree::PrimitiveType::Point, c);
  std::get<blobtree::Primitive>(n.kind).colour = colour;
  return n;
}

inline blobtree::Node combine(blobtree::OperatorType t, std::vector<blobtree::Node> children,
                              double power = 2.0) {
  blobtree::Operator o;
  o.type = t;
  o.power = power;
  return blobtree::Node{o, "", {}, std::move(children)};
}

inline blobtree::Node warped(blobtree::WarpType type, int axis, int other, double factor,
                             blobtree::Node child) {
  blobtree::Warp w;
  w.type = type;
  w.axis = axis;
  w.otherAxis = other;
  w.factor = factor;
  if (type == blobtree::WarpType::Bend) {
    w.centre = 0.0;
    w.lo = -0.5;
    w.hi = 0.5;
  }
  return blobtree::Node{w, "", {}, {std::move(child)}};
}

// A box around every test model (the bend warp makes csg_warps unbounded to compile()).
inline blobtree::GridSettings testBounds() {
  blobtree::GridSettings s;
  s.boundsLo = glm::dvec3(-1.2);
  s.boundsHi = glm::dvec3(1.2);
  return s;
}

struct NamedModel {
  std::string name;
  blobtree::Node root;
};

inline std::vector<NamedModel> testModels() {
  using P = blobtree::PrimitiveType;
  using O = blobtree::OperatorType;
  using W = blobtree::WarpType;
  std::vector<NamedModel> models;
  models.push_back({"point", pointAt({0, 0, 0})});
  models.push_back({"blend", combine(O::Blend, {pointAt({-0.4, 0, 0}, {1, 0, 0}),
                                                pointAt({0.4, 0, 0}, {0, 0, 1}),
                                                pointAt({0, 0.5, 0.1}, {0, 1, 0})})});
  auto cylinder = prim(P::Cylinder, {0, -0.5, 0}, {0, 1, 0}, 0.2, 1.0);
  auto cube = prim(P::Cube, {0, 0, 0}, {0.4, 0.3, 0.3});
  cube.transform.rotate = glm::angleAxis(0.5, glm::dvec3(0, 0, 1));
  auto ring = prim(P::Ring, {0.3, 0.2, 0}, {0, 0, 1}, 0.4);
  auto disc = prim(P::Disc, {-0.3, 0.3, 0}, {1, 0, 0}, 0.3);
  auto line = prim(P::Line, {-0.6, -0.4, 0}, {0.6, -0.3, 0.2});
  auto tri = prim(P::Triangle, {-0.4, 0, -0.3}, {0.4, 0.1, -0.3});
  std::get<blobtree::Primitive>(tri.kind).c = {0, 0.5, -0.2};
  auto quadric = prim(P::QuadricPoint, {0, 0, 0.4});
  std::get<blobtree::Primitive>(quadric.kind).scale = 0.9;
  models.push_back(
      {"csg_warps",
       combine(O::Union,
               {combine(O::Difference,
                        {warped(W::Twist, 1, 0, 1.2, cube), combine(O::Blend, {cylinder})}),
                combine(O::Ricci, {ring, warped(W::Bend, 0, 1, 0.8, disc)}, 3.0),
                combine(O::Intersection,
                        {warped(W::Taper, 2, 0, 0.5, line), prim(P::Point, {0, -0.35, 0.1})}),
                combine(O::SmoothDifference,
                        {warped(W::Shear, 0, 1, 0.3, tri), quadric})})});
  // A Ricci power whose children's powers fall below the smallest normal float near the surface
  // (0.5^200 is 6e-61): every backend flushes them to 0 alike (blobtree/pow_field.h).
  models.push_back({"ricci_p200", combine(O::Ricci, {pointAt({-0.3, 0, 0}, {1, 0, 0}), ring}, 200.0)});
  return models;
}

}  // namespace blobvk::testing
