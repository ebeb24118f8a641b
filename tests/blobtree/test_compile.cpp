// compile(): the Program preserves the field of the tree (against a double-precision tree walk),
// registers stay minimal for every tree shape, boxes never change the field, and records stay
// small.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/pow_field.h"
#include "blobvk/blobtree/program.h"
#include "test_helpers.h"
#include "tree_walk.h"

#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <random>

using namespace blobvk;
using namespace blobvk::blobtree;
using blobvk::testing::op;
using blobvk::testing::point;

namespace {

// Random trees with every node type. std::mt19937 is fully specified by the standard; only the
// raw engine output is used so the trees are the same everywhere.
class TreeMaker {
 public:
  explicit TreeMaker(unsigned seed) : rng_(seed) {}

  double uniform(double lo, double hi) { return lo + (hi - lo) * double(rng_()) / 4294967296.0; }
  int pick(int n) { return int(rng_() % unsigned(n)); }
  glm::dvec3 vec(double lo, double hi) { return {uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)}; }

  Transform transform() {
    Transform t;
    if (pick(2)) t.translate = vec(-0.5, 0.5);
    if (pick(2)) t.rotate = glm::angleAxis(uniform(-3, 3), glm::normalize(vec(-1, 1) + glm::dvec3(0, 0, 0.01)));
    if (pick(3) == 0) t.scale = vec(0.6, 1.5);
    return t;
  }

  Node primitive() {
    Primitive p;
    p.type = PrimitiveType(pick(8));
    p.a = vec(-0.6, 0.6);
    p.b = vec(-0.6, 0.6);
    p.c = vec(-0.6, 0.6);
    p.radius = uniform(0.1, 0.6);
    p.height = uniform(0.1, 0.8);
    p.scale = uniform(0.5, 1.5);
    p.support = uniform(0.6, 1.4);
    if (p.type == PrimitiveType::Cylinder || p.type == PrimitiveType::Disc || p.type == PrimitiveType::Ring) {
      p.b = glm::normalize(p.b + glm::dvec3(0, 0.01, 0));
    }
    if (p.type == PrimitiveType::Cube) p.b = glm::abs(p.b) + 0.05;
    p.colour = vec(0, 1);
    Node n{p, "", transform(), {}};
    return n;
  }

  Node tree(int depth) {
    if (depth == 0 || pick(4) == 0) return primitive();
    if (pick(5) == 0) {
      Warp w;
      w.type = WarpType(pick(4));
      w.axis = pick(3);
      w.otherAxis = (w.axis + 1 + pick(2)) % 3;
      w.factor = uniform(-0.8, 0.8);
      w.centre = uniform(-0.3, 0.3);
      w.lo = uniform(-1.0, -0.2);
      w.hi = uniform(0.2, 1.0);
      Node n{w, "", transform(), {}};
      n.children.push_back(tree(depth - 1));
      return n;
    }
    Operator o;
    o.type = OperatorType(pick(6));
    o.power = uniform(1.0, 8.0);
    Node n{o, "", transform(), {}};
    const int count = 2 + pick(3);
    for (int i = 0; i < count; ++i) n.children.push_back(tree(depth - 1));
    return n;
  }

 private:
  std::mt19937 rng_;
};

// The Program's records are float; evaluatePrecise() runs them in double so the comparison
// measures what compile() did (record rounding: ~1e-7), not float evaluation noise. The float
// evaluator is compared with the precise one separately.
double maxDifference(const Node& tree, const Program& program, TreeMaker& rng, int samples) {
  double worst = 0;
  for (int i = 0; i < samples; ++i) {
    const glm::dvec3 p = rng.vec(-2.0, 2.0);
    const double expected = blobvk::testing::treeWalkField(tree, p);
    const double actual = evaluatePrecise(program, p);
    worst = std::max(worst, std::abs(expected - actual));
  }
  return worst;
}

float fieldAt(const Node& n, glm::vec3 p) { return evaluate(compile(n), p); }

Node primitiveNode(Primitive p) { return Node{p, "", {}, {}}; }

}  // namespace

TEST(PrimitiveDistance, HandComputedCases) {
  const auto k = [](double dd) { return float(std::pow(1.0 - dd, 3)); };
  Primitive pt;
  EXPECT_NEAR(fieldAt(primitiveNode(pt), {0.3f, 0, 0}), k(0.09), 1e-6);
  pt.support = 2.0;
  EXPECT_NEAR(fieldAt(primitiveNode(pt), {0.6f, 0, 0}), k(0.09), 1e-6);

  Primitive line;
  line.type = PrimitiveType::Line;
  line.b = {1, 0, 0};
  EXPECT_NEAR(fieldAt(primitiveNode(line), {0.5f, 0.5f, 0}), k(0.25), 1e-6);
  EXPECT_NEAR(fieldAt(primitiveNode(line), {1.3f, 0.4f, 0}), k(0.25), 1e-6);  // clamped end
  EXPECT_EQ(fieldAt(primitiveNode(line), {2.0f, 0.5f, 0}), 0.0f);

  Primitive cyl;
  cyl.type = PrimitiveType::Cylinder;
  cyl.b = {0, 1, 0};
  cyl.radius = 0.5;
  cyl.height = 1.0;
  EXPECT_NEAR(fieldAt(primitiveNode(cyl), {0.8f, 0.5f, 0}), k(0.09), 1e-6);
  EXPECT_NEAR(fieldAt(primitiveNode(cyl), {0, -0.3f, 0}), k(0.09), 1e-6);    // below the base
  EXPECT_NEAR(fieldAt(primitiveNode(cyl), {0.1f, 1.2f, 0}), k(0.04), 1e-6);  // above the cap
  EXPECT_NEAR(fieldAt(primitiveNode(cyl), {0.8f, 1.4f, 0}), k(0.25), 1e-6);  // past the rim

  Primitive disc;
  disc.type = PrimitiveType::Disc;
  disc.b = {0, 1, 0};
  disc.radius = 1.0;
  EXPECT_NEAR(fieldAt(primitiveNode(disc), {0.5f, 0.4f, 0}), k(0.16), 1e-6);
  EXPECT_NEAR(fieldAt(primitiveNode(disc), {0, 0.4f, 1.3f}), k(0.25), 1e-6);

  Primitive ring = disc;
  ring.type = PrimitiveType::Ring;
  EXPECT_EQ(fieldAt(primitiveNode(ring), {0, 0, 0}), 0.0f);  // centre is radius 1 away
  EXPECT_NEAR(fieldAt(primitiveNode(ring), {0.7f, 0, 0}), k(0.09), 1e-6);
  EXPECT_NEAR(fieldAt(primitiveNode(ring), {0, 0.3f, -1.0f}), k(0.09), 1e-6);

  Primitive cube;
  cube.type = PrimitiveType::Cube;
  cube.b = {1, 0.5, 0.5};
  EXPECT_NEAR(fieldAt(primitiveNode(cube), {1.2f, 0.7f, 0}), k(0.08), 1e-6);
  EXPECT_NEAR(fieldAt(primitiveNode(cube), {0.9f, 0.1f, -0.2f}), 1.0f, 1e-6);

  Primitive tri;
  tri.type = PrimitiveType::Triangle;
  tri.a = {0, 0, 0};
  tri.b = {1, 0, 0};
  tri.c = {0, 1, 0};
  EXPECT_NEAR(fieldAt(primitiveNode(tri), {0.2f, 0.2f, 0.3f}), k(0.09), 1e-6);   // face
  EXPECT_NEAR(fieldAt(primitiveNode(tri), {1.2f, 0, 0}), k(0.04), 1e-6);         // vertex
  EXPECT_NEAR(fieldAt(primitiveNode(tri), {0.6f, 0.6f, 0}), k(0.02), 1e-6);      // hypotenuse
  EXPECT_NEAR(fieldAt(primitiveNode(tri), {-0.2f, 0.5f, 0.1f}), k(0.05), 1e-6);  // edge x = 0

  Primitive quadric;
  quadric.type = PrimitiveType::QuadricPoint;
  quadric.scale = 2.0;
  EXPECT_NEAR(fieldAt(primitiveNode(quadric), {0.5f, 0, 0}), 2.0 * 0.75 * 0.75, 1e-6);
  EXPECT_EQ(fieldAt(primitiveNode(quadric), {1.5f, 0, 0}), 0.0f);
}

TEST(Operators, CombineChildFields) {
  const Node a = point({0, 0, 0}), b = point({0.5, 0, 0});
  const glm::vec3 p{0.2f, 0.1f, 0};
  const double fa = blobvk::testing::treeWalkField(a, p), fb = blobvk::testing::treeWalkField(b, p);
  EXPECT_NEAR(fieldAt(op(OperatorType::Blend, {a, b}), p), fa + fb, 1e-6);
  EXPECT_NEAR(fieldAt(op(OperatorType::Union, {a, b}), p), std::max(fa, fb), 1e-6);
  EXPECT_NEAR(fieldAt(op(OperatorType::Intersection, {a, b}), p), std::min(fa, fb), 1e-6);
  EXPECT_NEAR(fieldAt(op(OperatorType::Difference, {a, b}), p), std::min(fa, 1 - fb), 1e-6);
  EXPECT_NEAR(fieldAt(op(OperatorType::SmoothDifference, {a, b}), p), fa * (1 - fb), 1e-6);
  EXPECT_NEAR(fieldAt(op(OperatorType::Ricci, {a, b}, 4.0), p), std::pow(std::pow(fa, 4) + std::pow(fb, 4), 0.25), 1e-6);
}

// OP_POW's float semantics (blobtree/pow_field.h): std::pow on the clamped base, results below the
// smallest normal float flushed to +0; its double bounds flush alike and overflow to +inf.
TEST(Operators, PowFlushesResultsBelowTheSmallestNormalFloat) {
  EXPECT_EQ(blobvk::blobtree::powField(0.9f, 2.0f), std::pow(0.9f, 2.0f));
  EXPECT_EQ(blobvk::blobtree::powField(-0.5f, 3.0f), 0.0f);
  EXPECT_GT(std::pow(0.7f, 250.0f), 0.0f);  // a denormal on the CPU, 0 where a device flushes
  EXPECT_EQ(blobvk::blobtree::powField(0.7f, 250.0f), 0.0f);
  EXPECT_EQ(blobvk::blobtree::powField(0.5f, 126.0f), std::ldexp(1.0f, -126));  // the smallest normal stays
  double lo = 0.7, hi = 0.95;
  blobvk::blobtree::powFieldBounds(lo, hi, 250.0);
  EXPECT_EQ(lo, 0.0);
  EXPECT_NEAR(hi, std::pow(0.95, 250.0), 1e-12);
  lo = 1.2, hi = 2.0;
  blobvk::blobtree::powFieldBounds(lo, hi, 300.0);  // 1.2^300 is 5e23; 2^300 overflows a float
  EXPECT_EQ(lo, std::pow(1.2, 300.0));
  EXPECT_TRUE(std::isinf(hi));
  // A Ricci blend of fields of 0.7 at power 250: every term flushes, so the blend is 0.
  const Node a = point({0, 0, 0}), b = point({0.5, 0, 0});
  const glm::vec3 p{0.25f, 0.3f, 0};
  ASSERT_GT(blobvk::testing::treeWalkField(a, p), 0.1);
  ASSERT_LT(blobvk::testing::treeWalkField(a, p), 0.7);
  EXPECT_EQ(fieldAt(op(OperatorType::Ricci, {a, b}, 250.0), p), 0.0f);
}

// Warps nest at most 7 deep (8 point registers); an eighth is refused, naming the outermost
// warp of the chain by its id.
// The grid follows the model's own size however small (a floor of 1e-6 once left a model of
// 2e-8 with no cell inside it), and cells finer than float resolves at the model's coordinates
// are refused with a line saying so.
TEST(Grid, SmallModelsGetTheirOwnCellsAndCellsBelowFloatPrecisionAreRefused) {
  Node tiny = point({0, 0, 0});
  tiny.transform.scale = {1e-8, 1e-8, 1e-8};
  const Program small = compile(tiny);
  const float extent = small.bounds.hi.x - small.bounds.lo.x;
  ASSERT_GT(extent, 0.0f);
  ASSERT_LT(extent, 1e-6f);
  GridRequest request;
  request.resolution = 16;
  const GridSpec grid = chooseGrid(small, {}, request);
  EXPECT_FLOAT_EQ(grid.cellSize, extent / 16.0f);
  EXPECT_EQ(grid.cells.x, 18);  // 16 and a cell of margin on each side

  Node far = point({0, 0, 0});
  far.transform.translate = {1e6, 0, 0};
  request.resolution = 10000;  // cells of 2e-4 at x = 1e6, where a float's step is 0.0625
  try {
    (void)chooseGrid(compile(far), {}, request);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("below float precision"), std::string::npos) << e.what();
  }
  request.resolution = 2;  // cells of 1, 16 steps of a float there: fine
  EXPECT_NO_THROW((void)chooseGrid(compile(far), {}, request));
}

// `inner` inside `levels` twists, one inside the other.
Node nestedTwists(int levels, double factor, Node inner) {
  Warp twist;
  twist.type = WarpType::Twist;
  twist.factor = factor;
  for (int k = 0; k < levels; ++k) inner = blobvk::testing::warp(twist, std::move(inner));
  return inner;
}

TEST(Warps, NestMostSevenDeep) {
  Node n = nestedTwists(7, 0.1, point({0, 0, 0}));
  EXPECT_NO_THROW((void)compile(n));
  n = nestedTwists(1, 0.1, std::move(n));
  n.id = "outermost";
  try {
    (void)compile(n);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("warps nested deeper than 7: a twist warp (id \"outermost\") holds 7 more"),
              std::string::npos)
        << e.what();
  }
}

TEST(Warps, MovePointsAsDocumented) {
  // A point at (1, 0, 1) twisted about z by 90 degrees per unit: the field peak sits where the
  // warp maps onto (1, 0, 1), i.e. rotated by -90 degrees: (0, -1, 1).
  Warp twist;
  twist.type = WarpType::Twist;
  twist.axis = 2;
  twist.factor = M_PI / 2;
  const Node n = blobvk::testing::warp(twist, point({1, 0, 1}));
  EXPECT_NEAR(fieldAt(n, {0, -1, 1}), 1.0f, 1e-5);

  Warp shear;
  shear.type = WarpType::Shear;
  shear.axis = 0;
  shear.otherAxis = 1;
  shear.factor = 0.5;
  EXPECT_NEAR(fieldAt(blobvk::testing::warp(shear, point({0, 1, 0})), {-0.5f, 1, 0}), 1.0f, 1e-6);

  Warp taper;
  taper.type = WarpType::Taper;
  taper.axis = 2;
  taper.otherAxis = 0;
  taper.factor = 1.0;
  EXPECT_NEAR(fieldAt(blobvk::testing::warp(taper, point({1, 0, 1})), {0.5f, 0, 1}), 1.0f, 1e-6);
}

TEST(Compile, PreservesTheFieldOfRandomTrees) {
  TreeMaker rng(7);
  for (int t = 0; t < 200; ++t) {
    const Node tree = rng.tree(4);
    const Program program = compile(tree);
    EXPECT_LE(maxDifference(tree, program, rng, 300), 1e-6) << "tree " << t;
  }
}

TEST(Evaluate, FloatEvaluatorTracksThePreciseOne) {
  TreeMaker rng(13);
  double worst = 0;
  for (int t = 0; t < 100; ++t) {
    const Program program = compile(rng.tree(4));
    for (int i = 0; i < 200; ++i) {
      const glm::dvec3 p = rng.vec(-2.0, 2.0);
      worst = std::max(worst, std::abs(double(evaluate(program, glm::vec3(p))) - evaluatePrecise(program, p)));
    }
  }
  // Float rounding through a few dozen operations on values of order 1.
  EXPECT_LE(worst, 2e-5);
}

TEST(Compile, BoxSkipsNeverChangeTheField) {
  TreeMaker rng(11);
  CompileOptions noSkips;
  noSkips.boxSkips = false;
  for (int t = 0; t < 100; ++t) {
    const Node tree = rng.tree(5);
    const Program with = compile(tree), without = compile(tree, noSkips);
    for (int i = 0; i < 200; ++i) {
      const glm::vec3 p(rng.vec(-2.5, 2.5));
      ASSERT_NEAR(evaluate(with, p), evaluate(without, p), 1e-6) << "tree " << t;
    }
  }
}

TEST(Compile, ColourFollowsTheWinningChild) {
  Node red = point({-0.3, 0, 0}), blue = point({0.3, 0, 0});
  std::get<Primitive>(red.kind).colour = {1, 0, 0};
  std::get<Primitive>(blue.kind).colour = {0, 0, 1};
  const Program u = compile(op(OperatorType::Union, {red, blue}));
  EXPECT_GT(evaluateWithColour(u, {-0.4f, 0, 0}).colour.x, 0.99f);
  EXPECT_GT(evaluateWithColour(u, {0.4f, 0, 0}).colour.z, 0.99f);
  const FieldColour mid = evaluateWithColour(compile(op(OperatorType::Blend, {red, blue})), {0, 0, 0});
  EXPECT_NEAR(mid.colour.x, 0.5f, 0.01f);
  EXPECT_NEAR(mid.colour.z, 0.5f, 0.01f);
}

namespace {
Node caterpillar(int n) {
  Node t = point({0, 0, 0});
  for (int i = 1; i < n; ++i) t = op(OperatorType::Union, {std::move(t), point({0.01 * i, 0, 0})});
  return t;
}
Node rightDeep(OperatorType type, int n) {
  Node t = point({0, 0, 0});
  for (int i = 1; i < n; ++i) t = op(type, {point({0.01 * i, 0, 0}), std::move(t)});
  return t;
}
Node balanced(int levels, double x = 0) {
  if (levels == 0) return point({x, 0, 0});
  return op(OperatorType::Blend, {balanced(levels - 1, x), balanced(levels - 1, x + std::ldexp(1.0, levels))});
}
}  // namespace

TEST(Registers, MinimalForEveryTreeShape) {
  EXPECT_EQ(compile(point({0, 0, 0})).fieldRegisters, 1u);
  EXPECT_EQ(compile(caterpillar(200)).fieldRegisters, 2u);
  EXPECT_EQ(compile(rightDeep(OperatorType::Union, 200)).fieldRegisters, 2u);
  // Right-deep differences would need one register per level without the 1 - f form.
  EXPECT_EQ(compile(rightDeep(OperatorType::Difference, 200)).fieldRegisters, 2u);
  EXPECT_EQ(compile(rightDeep(OperatorType::SmoothDifference, 200)).fieldRegisters, 2u);
  for (int levels = 1; levels <= 10; ++levels) {
    EXPECT_EQ(compile(balanced(levels)).fieldRegisters, std::uint32_t(levels + 1)) << levels;
  }
  std::vector<Node> wide;
  for (int i = 0; i < 500; ++i) wide.push_back(point({0.01 * i, 0, 0}));
  EXPECT_EQ(compile(op(OperatorType::Blend, std::move(wide))).fieldRegisters, 2u);
}

TEST(Registers, ReorderedDifferenceKeepsItsField) {
  TreeMaker rng(3);
  const Node tree = rightDeep(OperatorType::Difference, 12);
  const Node smooth = rightDeep(OperatorType::SmoothDifference, 12);
  EXPECT_LE(maxDifference(tree, compile(tree), rng, 500), 1e-6);
  EXPECT_LE(maxDifference(smooth, compile(smooth), rng, 500), 1e-6);
}

TEST(Registers, WarpsInsideWarpsUseOnePointRegisterPerLevel) {
  Node n = nestedTwists(5, 0.3, point({0.2, 0, 0}));
  const Program p = compile(n);
  EXPECT_EQ(p.pointRegisters, 6u);
  TreeMaker rng(5);
  EXPECT_LE(maxDifference(n, p, rng, 300), 1e-6);
  n = nestedTwists(3, 0.3, std::move(n));  // 8 deep: Warps.NestMostSevenDeep
  EXPECT_THROW(compile(n), std::invalid_argument);
}

TEST(Transforms, FoldIntoOneMatrixPerPrimitive) {
  Node a = point({0, 0, 0}), b = point({0, 0, 0});
  b.transform.translate = {1, 0, 0};
  Node top = op(OperatorType::Blend, {a, b});
  top.transform.scale = {2, 2, 2};
  top.transform.translate = {0, 3, 0};
  const Program p = compile(top);
  // Identity + one matrix per primitive; no matrix for the operator.
  EXPECT_EQ(p.matrices.size(), 3u);
  // b's centre ends at (2, 3, 0) in world space with a support radius of 2.
  // a sits at (0, 3, 0): exactly one support radius away, so only b contributes.
  EXPECT_NEAR(evaluate(p, {2, 3, 0}), 1.0f, 1e-6);
  EXPECT_NEAR(evaluate(p, {2, 4, 0}), float(std::pow(1 - 0.25, 3)), 1e-6);
  EXPECT_NEAR(evaluate(p, {1, 3, 0}), 2.0f * float(std::pow(1 - 0.25, 3)), 1e-6);
  // Untransformed primitives get the shared identity.
  EXPECT_EQ(compile(point({1, 2, 3})).primitives[0].meta.y, 0u);
}

TEST(Bounds, ContainTheFullKernelSupport) {
  Node n = point({1, 0, 0});
  n.transform.scale = {2, 1, 1};
  const Program p = compile(n);
  EXPECT_NEAR(p.bounds.lo.x, 0.0f, 1e-5);  // centre at x = 2, support 2 along x
  EXPECT_NEAR(p.bounds.hi.x, 4.0f, 1e-5);
  EXPECT_NEAR(p.bounds.hi.y, 1.0f, 1e-5);
  // The field is 0 on and beyond the box in every direction.
  EXPECT_EQ(evaluate(p, {4.001f, 0, 0}), 0.0f);
  EXPECT_GT(evaluate(p, {3.9f, 0, 0}), 0.0f);
}

// Program::primitiveBoxes promise a field of exactly 0 outside (code generators drop the
// primitive there): sample each primitive of random trees around and beyond its box.
TEST(Bounds, PrimitiveBoxesHoldEveryNonZeroField) {
  TreeMaker rng(23);
  std::size_t outside = 0, insideNonZero = 0;
  for (int t = 0; t < 60; ++t) {
    const Program program = compile(rng.tree(4));
    ASSERT_EQ(program.primitiveBoxes.size(), program.primitives.size());
    for (std::size_t i = 0; i < program.primitives.size(); ++i) {
      const auto& box = program.primitiveBoxes[i];
      const glm::vec3 lo(box.lo.x, box.lo.y, box.lo.z), hi(box.hi.x, box.hi.y, box.hi.z);
      ASSERT_TRUE(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z);
      const glm::vec3 size = hi - lo;
      for (int s = 0; s < 300; ++s) {
        // Points in the box grown by half its size on every side: a third of them outside.
        const glm::vec3 p = lo - 0.5f * size + glm::vec3(rng.vec(0.0, 1.0)) * 2.0f * size;
        const float f = primitiveField(program, program.primitives[i], p);
        const bool in = glm::all(glm::greaterThanEqual(p, lo)) && glm::all(glm::lessThanEqual(p, hi));
        if (!in) {
          ++outside;
          ASSERT_EQ(f, 0.0f) << "tree " << t << " primitive " << i;
        } else {
          insideNonZero += f > 0.0f;
        }
      }
    }
  }
  EXPECT_GT(outside, 10000u);
  EXPECT_GT(insideNonZero, 1000u);  // the boxes are not trivially huge: the field lives in them
}

TEST(ProgramSize, SixtyFourThousandNodesFitInEightMiB) {
  // 32768 primitives under a balanced tree of blends and unions with a transform on each.
  std::vector<Node> level;
  for (int i = 0; i < 32768; ++i) {
    Node p = point({0, 0, 0});
    p.transform.translate = {double(i % 32), double((i / 32) % 32), double(i / 1024)};
    level.push_back(std::move(p));
  }
  int flip = 0;
  while (level.size() > 1) {
    std::vector<Node> next;
    for (std::size_t i = 0; i + 1 < level.size(); i += 2) {
      next.push_back(op(flip ? OperatorType::Union : OperatorType::Blend, {std::move(level[i]), std::move(level[i + 1])}));
    }
    level = std::move(next);
    flip ^= 1;
  }
  const Program p = compile(level.front());
  EXPECT_EQ(p.primitives.size(), 32768u);
  EXPECT_LE(p.byteSize(), 8u << 20) << p.byteSize();
  EXPECT_EQ(p.fieldRegisters, 16u);
}
