// Analytic gradients (blobtree/gradient.h) against central differences of the double-precision
// evaluator (evaluatePrecise: another code path and another precision), on every primitive,
// operator and warp, each with a transform, and on random trees mixing them. Points within a
// difference step of a crease (where min/max/clamp switch branches, so the one-sided analytic
// gradient and the straddling difference legitimately disagree) are recognised by two step sizes
// disagreeing and left out; each case must still keep most of its points.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/gradient.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <random>
#include <string>

namespace {

using namespace blobvk::blobtree;
using blobvk::testing::op;

glm::dvec3 centralDifference(const Program& program, const glm::dvec3& p, double h) {
  glm::dvec3 g;
  for (int axis = 0; axis < 3; ++axis) {
    glm::dvec3 a = p, b = p;
    a[axis] += h;
    b[axis] -= h;
    g[axis] = (evaluatePrecise(program, a) - evaluatePrecise(program, b)) / (2.0 * h);
  }
  return g;
}

struct Checked {
  int seen = 0, compared = 0, nearCrease = 0;
  double worst = 0;  // largest |analytic - difference| / max(1, |difference|)
};

// Random points in the box until `samples` of them see a non-zero field (where the gradient is
// not trivially zero).
Checked check(const Program& program, std::mt19937& rng, glm::dvec3 lo, glm::dvec3 hi, int samples) {
  Checked c;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int tries = 0; tries < 100 * samples && c.seen < samples; ++tries) {
    const glm::dvec3 p = lo + (hi - lo) * glm::dvec3(u(rng), u(rng), u(rng));
    const glm::vec3 pf(p);
    const FieldGradient fg = evaluateGradient(program, pf);
    EXPECT_EQ(fg.field, evaluate(program, pf)) << "the gradient pass computes the field's bits";
    if (evaluatePrecise(program, glm::dvec3(pf)) == 0.0) continue;
    ++c.seen;
    const glm::dvec3 q(pf);  // the float point, so both sides look at the same place
    const glm::dvec3 fine = centralDifference(program, q, 1e-5), coarse = centralDifference(program, q, 4e-5);
    const double scale = std::max(1.0, glm::length(fine));
    if (glm::length(fine - coarse) > 1e-4 * scale) {
      ++c.nearCrease;
      continue;
    }
    ++c.compared;
    c.worst = std::max(c.worst, glm::length(glm::dvec3(fg.gradient) - fine) / scale);
  }
  return c;
}

Transform someTransform(double angle) {
  Transform t;
  t.translate = {0.1, -0.2, 0.15};
  t.rotate = glm::angleAxis(angle, glm::normalize(glm::dvec3(0.3, 1.0, -0.4)));
  t.scale = {1.2, 0.8, 1.1};
  return t;
}

Node primitive(PrimitiveType type, glm::dvec3 at, double angle = 0.7) {
  Primitive p;
  p.type = type;
  p.a = at;
  p.b = type == PrimitiveType::Cube ? glm::dvec3(0.3, 0.2, 0.25)
        : type == PrimitiveType::Line || type == PrimitiveType::Triangle ? at + glm::dvec3(0.5, 0.2, -0.1)
                                                                            : glm::normalize(glm::dvec3(0.2, 1.0, 0.3));
  p.c = at + glm::dvec3(-0.1, 0.4, 0.3);
  p.radius = 0.35;
  p.height = 0.5;
  p.scale = 1.3;
  p.support = 0.9;
  return Node{p, "", someTransform(angle), {}};
}

void expectGradientsMatch(const Node& tree, const std::string& what, int samples = 400) {
  const Program program = compile(tree);
  std::mt19937 rng(7);
  const glm::dvec3 lo(program.bounds.lo), hi(program.bounds.hi);
  const Checked c = check(program, rng, glm::max(lo, glm::dvec3(-2)), glm::min(hi, glm::dvec3(2)), samples);
  EXPECT_LT(c.worst, 2e-3) << what;
  EXPECT_EQ(c.seen, samples) << what << ": the samples must see the field";
  EXPECT_GT(c.compared, samples * 3 / 4) << what << ": too many points near creases (" << c.nearCrease << ")";
}

TEST(Gradient, EveryPrimitiveWithATransform) {
  for (std::uint32_t t = 0; t <= 7; ++t)
    expectGradientsMatch(primitive(PrimitiveType(t), {0.1, 0.0, -0.1}), toString(PrimitiveType(t)));
}

TEST(Gradient, EveryOperator) {
  for (std::uint32_t t = 0; t <= 5; ++t) {
    Node n = op(OperatorType(t),
                {primitive(PrimitiveType::Line, {-0.3, 0, 0}), primitive(PrimitiveType::Point, {0.3, 0.1, 0}, 0.2),
                 primitive(PrimitiveType::Cube, {0.0, 0.3, 0.1}, 1.3)},
                3.0);
    n.transform = someTransform(-0.4);
    expectGradientsMatch(n, toString(OperatorType(t)));
  }
  // Ricci with a root below 1 and above 1.
  expectGradientsMatch(op(OperatorType::Ricci, {primitive(PrimitiveType::Point, {-0.2, 0, 0}),
                                                primitive(PrimitiveType::Disc, {0.2, 0, 0})},
                          0.5),
                       "ricci 0.5");
}

TEST(Gradient, EveryWarpWithATransformAndNested) {
  for (std::uint32_t t = 0; t <= 3; ++t) {
    Warp w;
    w.type = WarpType(t);
    w.axis = 1;
    w.otherAxis = 0;
    w.factor = 0.9;
    w.centre = 0.1;
    w.lo = -0.3;  // bend: points before, inside and past the bent region
    w.hi = 0.4;
    Node inner = op(OperatorType::Blend, {primitive(PrimitiveType::Line, {0, -0.6, 0}), primitive(PrimitiveType::Cylinder, {0.1, 0.2, 0})});
    Node n = blobvk::testing::warp(w, inner);
    n.transform = someTransform(0.3);
    expectGradientsMatch(n, toString(WarpType(t)));
    Warp outer = w;
    outer.type = WarpType((t + 1) % 4);
    outer.axis = 2;
    outer.otherAxis = 1;
    Node nested = blobvk::testing::warp(outer, n);
    nested.transform = someTransform(-1.1);
    expectGradientsMatch(nested, std::string(toString(WarpType(t))) + " inside " + toString(outer.type));
  }
}

TEST(Gradient, RandomTreesOfEveryNodeType) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> pick(0, 1 << 30);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  // Trees of depth 3 from the node kinds above, shuffled: every operator over warped and
  // transformed primitives of every type.
  for (int trial = 0; trial < 12; ++trial) {
    std::vector<Node> children;
    for (int c = 0; c < 3; ++c) {
      Node leaf = primitive(PrimitiveType(pick(rng) % 8), {u(rng), u(rng), u(rng)}, u(rng) * 4);
      if (pick(rng) % 2) {
        Warp w;
        w.type = WarpType(pick(rng) % 4);
        w.axis = pick(rng) % 3;
        w.otherAxis = (w.axis + 1 + pick(rng) % 2) % 3;
        w.factor = u(rng);
        w.lo = -0.4, w.hi = 0.4;
        leaf = blobvk::testing::warp(w, leaf);
      }
      children.push_back(leaf);
    }
    Node n = op(OperatorType(pick(rng) % 6), children, 1.0 + (pick(rng) % 50) / 10.0);
    expectGradientsMatch(op(OperatorType(pick(rng) % 6), {n, primitive(PrimitiveType(pick(rng) % 8), {u(rng), 0, 0})}, 2.5),
                         "random tree " + std::to_string(trial), 200);
  }
}

TEST(Gradient, NormalsAgreeWithCentralDifferencesAndColourRidesAlong) {
  const Node n = op(OperatorType::Blend, {primitive(PrimitiveType::Point, {-0.3, 0, 0}), primitive(PrimitiveType::Ring, {0.3, 0, 0})});
  const Program program = compile(n);
  for (float x = -1.0f; x <= 1.0f; x += 0.125f) {
    const glm::vec3 p(x, 0.2f, 0.1f);
    const FieldGradient fg = evaluateGradientColour(program, p);
    EXPECT_EQ(fg.colour, evaluateWithColour(program, p).colour);
    if (glm::length(fg.gradient) < 1e-3f) continue;
    EXPECT_LT(glm::length(analyticNormal(program, p) - normal(program, p)), 1e-2f) << x;
  }
  EXPECT_EQ(outwardNormal(glm::vec3(0.0f)), glm::vec3(0, 0, 1));
}

}  // namespace
