// Every shipped scene loads, compiles and has its surface where its construction says; the
// generated ones are exactly what the generators produce.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "test_scene_compare.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <set>

using namespace blobvk::blobtree;
using blobvk::testing::countNodes;
using blobvk::testing::expectSameTree;

namespace {
const std::string kScenes = BLOBVK_SOURCE_DIR "/scenes/";

float fieldAt(const Program& p, double x, double y, double z) {
  return evaluate(p, glm::vec3(float(x), float(y), float(z)));
}
}  // namespace

TEST(ShippedScenes, EveryFileLoadsAndCompiles) {
  std::size_t files = 0;
  for (const auto& dir : {kScenes, kScenes + "legacy/"}) {
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      const auto ext = entry.path().extension();
      if (!entry.is_regular_file() || (ext != ".json" && ext != ".blob" && ext != ".scene")) continue;
      SCOPED_TRACE(entry.path().string());
      const Scene s = loadScene(entry.path().string());
      const Program p = compile(s.root);
      EXPECT_FALSE(p.code.empty());
      // A bend makes compile()'s box infinite; such scenes must give grid bounds themselves.
      EXPECT_TRUE(p.bounds.finite() || (s.grid.boundsLo && s.grid.boundsHi));
      if (s.grid.boundsLo && s.grid.boundsHi) {  // and the surface must lie inside them
        const Vec3 lo = *s.grid.boundsLo, hi = *s.grid.boundsHi;
        float worst = 0.0f;
        for (int i = 0; i <= 40; ++i)
          for (int j = 0; j <= 40; ++j)
            for (int axis = 0; axis < 3; ++axis)
              for (double side : {lo[axis], hi[axis]}) {
                Vec3 q;
                q[axis] = side;
                q[(axis + 1) % 3] = lo[(axis + 1) % 3] + (hi - lo)[(axis + 1) % 3] * i / 40.0;
                q[(axis + 2) % 3] = lo[(axis + 2) % 3] + (hi - lo)[(axis + 2) % 3] * j / 40.0;
                worst = std::max(worst, evaluate(p, glm::vec3(q)));
              }
        EXPECT_LT(worst, 0.5f) << "the surface crosses the scene's grid bounds";
      }
      ++files;
    }
  }
  EXPECT_GE(files, 9u);
}

TEST(ShippedScenes, GeneratedScenesMatchTheGenerators) {
  expectSameTree(loadScene(kScenes + "tower.json").root, generateTower(4, 8, 6.0, 6.0, 1));
  expectSameTree(loadScene(kScenes + "tower_L6P8I4.json").root, generateTower(6, 8, 6.0, 6.0, 4));
  expectSameTree(loadScene(kScenes + "eggshell.json").root, generateEggshell());
  expectSameTree(loadScene(kScenes + "random128.json").root, generateRandomBlobs(128, 1));
}

TEST(ShippedScenes, ShowcasesUseWarpsRicciAndCsgWithinBudget) {
  std::set<std::string> kinds;
  std::function<void(const Node&)> visit = [&](const Node& n) {
    if (const auto* o = std::get_if<Operator>(&n.kind)) kinds.insert(toString(o->type));
    if (const auto* w = std::get_if<Warp>(&n.kind)) kinds.insert(toString(w->type));
    if (const auto* p = std::get_if<Primitive>(&n.kind)) kinds.insert(toString(p->type));
    for (const Node& c : n.children) visit(c);
  };
  for (const char* name : {"dice.json", "twisted_column.json", "creature.json"}) {
    const Scene s = loadScene(kScenes + name);
    EXPECT_LT(countNodes(s.root).primitives, 300u) << name;
    visit(s.root);
  }
  for (auto t : {WarpType::Twist, WarpType::Taper, WarpType::Bend, WarpType::Shear}) EXPECT_TRUE(kinds.count(toString(t)));
  for (auto t : {OperatorType::Ricci, OperatorType::Difference, OperatorType::Intersection})
    EXPECT_TRUE(kinds.count(toString(t)));
  EXPECT_EQ(kinds.size(), 8u + 4u + 5u) << "every primitive, every warp and five operator kinds";
}

TEST(ShippedScenes, SurfacesAreWhereTheModelsPutThem) {
  const Program tower = compile(loadScene(kScenes + "tower.json").root);
  EXPECT_GT(fieldAt(tower, 6.0, 2.0, 0.0), 0.5f) << "inside the first column";
  EXPECT_LT(fieldAt(tower, 0.0, 2.0, 0.0), 0.5f) << "the middle of a level is open";
  EXPECT_GT(fieldAt(tower, 0.0, 6.6 * 3 + 0.9 * 6.0, 0.0), 0.5f) << "inside the top ceiling";
  EXPECT_GT(fieldAt(tower, 6.0, 6.3, 0.0), 0.5f) << "ceiling and next level's base meet";

  const Program egg = compile(loadScene(kScenes + "eggshell.json").root);
  EXPECT_LT(fieldAt(egg, 0.0, 0.0, 0.0), 0.5f) << "hollow";
  EXPECT_GT(fieldAt(egg, 1.5, 0.0, 0.0), 0.5f) << "in the shell: between 0.454*3.14 and 0.454*3.45";

  const Program dice = compile(loadScene(kScenes + "dice.json").root);
  EXPECT_GT(fieldAt(dice, 0.0, 0.0, 0.0), 0.5f);
  // A cube of half-width 0.9 + 0.454 * 0.2 = 0.99 with flat faces, its corners rounded off by a
  // ball of radius 0.454 * 3 = 1.36, and pips dented into the faces.
  EXPECT_GT(fieldAt(dice, 0.95, 0.3, 0.3), 0.5f) << "face +x away from its pip";
  EXPECT_LT(fieldAt(dice, 1.05, 0.3, 0.3), 0.5f) << "the face is flat: a ball would reach 1.3";
  EXPECT_LT(fieldAt(dice, 0.95, 0.0, 0.0), 0.5f) << "the pip on face +x is a dent";
  EXPECT_GT(fieldAt(dice, 0.93, 0.93, 0.0), 0.5f) << "edges stay square";
  EXPECT_LT(fieldAt(dice, 0.9, 0.9, 0.9), 0.5f) << "corners are rounded off by the ball";

  const Program column = compile(loadScene(kScenes + "twisted_column.json").root);
  EXPECT_GT(fieldAt(column, 0.0, 4.0, 0.0), 0.5f);
  EXPECT_GT(fieldAt(column, 0.0, 8.7, 0.0), 0.5f) << "capital";
  EXPECT_LT(fieldAt(column, 1.4, 4.0, 1.4), 0.5f);

  const Program creature = compile(loadScene(kScenes + "creature.json").root);
  EXPECT_GT(fieldAt(creature, 0.0, 0.0, 0.0), 0.5f) << "the body passes the bend's centre unmoved";
  EXPECT_LT(fieldAt(creature, 0.0, 0.0, 2.0), 0.5f);
}
