// Edits as data: the region EditableTree::apply reports is checked against the scalar
// reference evaluator (outside it, the old and new Programs give the same field and colour
// bits), and the edits themselves against the tree they should produce.
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/scene_io.h"

#include "random_edits.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <bit>
#include <random>
#include <string>

namespace {

using namespace blobvk;
using namespace blobvk::blobtree;

const std::string kScenes = BLOBVK_SOURCE_DIR "/scenes/";

bool inside(const Region& r, const glm::vec3& p) {
  return p.x >= r.lo.x && p.y >= r.lo.y && p.z >= r.lo.z && p.x <= r.hi.x && p.y <= r.hi.y && p.z <= r.hi.z;
}

// Samples points around the model and counts those outside the region where the field or
// colour bits differ between the Programs; also counts differing points inside.
struct Differences {
  int outside = 0, inside = 0, sampledOutside = 0;
};
Differences compareFields(const Program& before, const Program& after, const Region& region,
                          glm::dvec3 lo, glm::dvec3 hi, std::mt19937& rng, int samples) {
  Differences d;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < samples; ++i) {
    // Half the points near the region's border, where a too-small region would show first.
    glm::dvec3 q = lo + (hi - lo) * glm::dvec3(u(rng), u(rng), u(rng));
    if (i % 2 && !region.empty() && !region.everything()) {
      const glm::dvec3 size = region.hi - region.lo;
      q = region.lo - 0.1 * size + 1.2 * size * glm::dvec3(u(rng), u(rng), u(rng));
    }
    const glm::vec3 p(q);
    const FieldColour a = evaluateWithColour(before, p), b = evaluateWithColour(after, p);
    const bool same = std::bit_cast<std::uint32_t>(a.field) == std::bit_cast<std::uint32_t>(b.field) &&
                      std::bit_cast<std::uint32_t>(evaluate(before, p)) == std::bit_cast<std::uint32_t>(evaluate(after, p)) &&
                      (a.colour == b.colour || a.field == 0.0f);
    if (inside(region, p)) {
      d.inside += !same;
    } else {
      ++d.sampledOutside;
      d.outside += !same;
    }
  }
  return d;
}

class RegionIsExact : public ::testing::TestWithParam<std::string> {};

TEST_P(RegionIsExact, OutsideTheRegionNothingChanges) {
  const Scene scene = loadScene(kScenes + GetParam());
  EditableTree tree(scene.root);
  // A bend at the root bounds nothing: then the scene's grid bounds.
  const Aabb b = tree.program().bounds;
  glm::dvec3 lo = glm::dvec3(b.lo) - 1.0, hi = glm::dvec3(b.hi) + 1.0;
  if (!b.finite()) {
    ASSERT_TRUE(scene.grid.boundsLo && scene.grid.boundsHi);
    lo = *scene.grid.boundsLo, hi = *scene.grid.boundsHi;
  }
  blobvk::testing::RandomEdits edits(7, lo, hi);
  std::mt19937 rng(11);
  int changedInside = 0, sampledOutside = 0;
  for (int step = 0; step < 60; ++step) {
    const Program before = tree.program();
    const Edit edit = edits.next(tree.root());
    const Region region = tree.apply(edit);
    const Differences d = compareFields(before, tree.program(), region, lo, hi, rng, 600);
    EXPECT_EQ(d.outside, 0) << GetParam() << " step " << step << " path " << toString(edit.path)
                            << " change " << edit.change.index();
    changedInside += d.inside;
    sampledOutside += d.sampledOutside;
  }
  // The check is not vacuous: edits changed the field somewhere, and most points lay outside.
  EXPECT_GT(changedInside, 0);
  EXPECT_GT(sampledOutside, 60 * 600 / 4);
}

INSTANTIATE_TEST_SUITE_P(Scenes, RegionIsExact,
                         ::testing::Values("tower.json", "random128.json", "dice.json",
                                           "twisted_column.json", "craniotomy.json", "eggshell.json"),
                         [](const auto& info) {
                           std::string n = info.param.substr(0, info.param.find('.'));
                           for (char& c : n) if (c == '_') c = 'x';
                           return n;
                         });

TEST(Edit, MovingAPrimitiveGivesItsOldAndNewBoxes) {
  using blobvk::testing::op;
  using blobvk::testing::point;
  EditableTree tree(op(OperatorType::Blend, {point({0, 0, 0}), point({5, 0, 0}, 2.0)}));
  Transform t;
  t.translate = {0, 3, 0};
  const Region r = tree.apply({{1}, SetTransform{t}});
  // Point at (5,0,0) of support 2, moved to (5,3,0): boxes [3,7]x[-2,2] and [3,7]x[1,5].
  EXPECT_NEAR(r.lo.x, 3.0, 1e-9);
  EXPECT_NEAR(r.hi.x, 7.0, 1e-9);
  EXPECT_NEAR(r.lo.y, -2.0, 1e-9);
  EXPECT_NEAR(r.hi.y, 5.0, 1e-9);
  EXPECT_NEAR(r.lo.z, -2.0, 1e-9);
  EXPECT_EQ(tree.node({1}).transform.translate, glm::dvec3(0, 3, 0));
  EXPECT_FLOAT_EQ(evaluate(tree.program(), {5, 3, 0}), 1.0f);
}

TEST(Edit, ThroughAWarpTheRegionIsUnwarped) {
  using blobvk::testing::point;
  Warp w;
  w.type = WarpType::Bend;
  w.factor = 0.2;
  EditableTree tree(blobvk::testing::op(OperatorType::Union, {blobvk::testing::warp(w, point({0, 1, 0})), point({9, 0, 0})}));
  Primitive p = std::get<Primitive>(tree.node({0, 0}).kind);
  p.support = 1.5;
  EXPECT_TRUE(tree.apply({{0, 0}, SetPrimitive{p}}).everything());  // a bend bounds nothing
  const Region r = tree.apply({{1}, SetPrimitive{std::get<Primitive>(tree.node({1}).kind)}});
  EXPECT_FALSE(r.everything());
  EXPECT_NEAR(r.lo.x, 8.0, 1e-9);
}

TEST(Edit, AddAndRemoveChildren) {
  using blobvk::testing::op;
  using blobvk::testing::point;
  EditableTree tree(op(OperatorType::Intersection, {point({0, 0, 0}, 2.0), point({1, 0, 0}, 2.0)}));
  const Region added = tree.apply({{}, AddChild{point({0.5, 0, 0}, 3.0), 1}});
  ASSERT_EQ(tree.root().children.size(), 3u);
  EXPECT_EQ(std::get<Primitive>(tree.node({1}).kind).support, 3.0);
  EXPECT_FALSE(added.empty());
  const Region removed = tree.apply({{}, RemoveChild{0}});
  ASSERT_EQ(tree.root().children.size(), 2u);
  EXPECT_EQ(std::get<Primitive>(tree.node({0}).kind).support, 3.0);
  EXPECT_FALSE(removed.empty());
  // The field is the intersection of the two remaining children.
  EXPECT_FLOAT_EQ(evaluate(tree.program(), {1, 0, 0}), evaluate(compile(tree.root()), {1, 0, 0}));
  EXPECT_FLOAT_EQ(evaluate(tree.program(), {1, 0, 0}), std::min(std::pow(1.f - 0.25f / 9.f, 3.f), 1.0f));
}

TEST(Edit, BadEditsLeaveTheTreeAsItWas) {
  using blobvk::testing::op;
  using blobvk::testing::point;
  EditableTree tree(op(OperatorType::Difference, {point({0, 0, 0}, 2.0), point({1, 0, 0})}));
  const std::vector<layout::Instruction> code = tree.program().code;
  const auto expectRefused = [&](const Edit& e, const std::string& words) {
    try {
      tree.apply(e);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const std::invalid_argument& err) {
      EXPECT_NE(std::string(err.what()).find(words), std::string::npos) << err.what();
    }
    EXPECT_EQ(tree.root().children.size(), 2u);
    EXPECT_EQ(tree.program().code.size(), code.size());
  };
  expectRefused({{2}, SetTransform{}}, "no node at path [2]");
  expectRefused({{}, SetPrimitive{}}, "not a primitive");
  expectRefused({{0}, SetOperator{}}, "not an operator");
  expectRefused({{}, RemoveChild{1}}, "needs at least 2");
  expectRefused({{0}, AddChild{point({0, 0, 0}), 0}}, "cannot add a child");
  Primitive zero = std::get<Primitive>(tree.node({1}).kind);
  zero.support = 0.0;
  expectRefused({{1}, SetPrimitive{zero}}, "support");
  EXPECT_EQ(std::get<Primitive>(tree.node({1}).kind).support, 1.0);
  EXPECT_EQ(tree.find("nothing"), std::nullopt);
}

TEST(Edit, FindsNodesById) {
  const Scene scene = loadScene(kScenes + "tower.json");
  EditableTree tree(scene.root);
  std::string id;
  const auto path = [&]() -> std::optional<NodePath> {
    // The first node with an id, whatever the scene calls it.
    std::vector<std::pair<const Node*, NodePath>> todo{{&tree.root(), {}}};
    while (!todo.empty()) {
      auto [n, p] = todo.back();
      todo.pop_back();
      if (!n->id.empty()) {
        id = n->id;
        return p;
      }
      for (std::size_t c = 0; c < n->children.size(); ++c) {
        NodePath q = p;
        q.push_back(c);
        todo.emplace_back(&n->children[c], q);
      }
    }
    return std::nullopt;
  }();
  ASSERT_TRUE(path.has_value());
  const auto found = tree.find(id);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(tree.node(*found).id, id);
}

}  // namespace
