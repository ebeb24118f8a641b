// Legacy .blob/.scene reader: the shipped legacy files, every primitive and warp, the old
// spellings (SkeletonType, lower-case operators, NUL bytes), instancing and shared children.
#include "blobvk/blobtree/scene_blob.h"
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"
#include "test_scene_compare.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace blobvk::blobtree;
using blobvk::testing::countNodes;
using blobvk::testing::expectSameTree;

namespace {
const std::string kScenes = BLOBVK_SOURCE_DIR "/scenes/legacy/";
const std::string kData = BLOBVK_SOURCE_DIR "/tests/data/scenes/";

const Primitive& prim(const Node& n) { return std::get<Primitive>(n.kind); }
const Warp& warp(const Node& n) { return std::get<Warp>(n.kind); }
OperatorType opType(const Node& n) { return std::get<Operator>(n.kind).type; }
}  // namespace

TEST(SceneBlob, PeanutIsABlendOfTwoScaledPoints) {
  const Scene s = loadScene(kScenes + "peanut.blob");
  ASSERT_TRUE(s.root.isOperator());
  EXPECT_EQ(opType(s.root), OperatorType::Blend);
  EXPECT_EQ(s.root.id, "0");
  ASSERT_EQ(s.root.children.size(), 2u);
  const Node& left = s.root.children[0];
  const Node& right = s.root.children[1];
  EXPECT_EQ(prim(left).type, PrimitiveType::Point);
  EXPECT_EQ(prim(left).a, Vec3(-0.5, 0.0, 0.0));
  EXPECT_EQ(left.transform.scale, Vec3(1.5));
  EXPECT_EQ(prim(left).colour, Vec3(0.8, 0.6, 0.4));  // MtrlDiffused
  EXPECT_EQ(right.transform.translate, Vec3(0.5, 0.0, 0.0));
  EXPECT_EQ(prim(right).colour, Vec3(0.75, 0.55, 0.35));
  EXPECT_EQ(prim(right).support, 1.0);
}

TEST(SceneBlob, TowerFragmentHasRicciDifferenceRangeAndInstance) {
  const Scene s = loadScene(kScenes + "tower_fragment.blob");
  EXPECT_EQ(opType(s.root), OperatorType::Union);
  ASSERT_EQ(s.root.children.size(), 3u);  // the NULL padding child is dropped
  const Node& pillar = s.root.children[0];
  EXPECT_EQ(opType(pillar), OperatorType::Ricci);
  EXPECT_EQ(std::get<Operator>(pillar.kind).power, 8.0);
  ASSERT_EQ(pillar.children.size(), 3u);  // ChildrenIDsRange=(3, 5)
  EXPECT_EQ(prim(pillar.children[0]).type, PrimitiveType::Disc);
  EXPECT_EQ(prim(pillar.children[0]).radius, 1.0);
  EXPECT_EQ(prim(pillar.children[1]).type, PrimitiveType::Cylinder);
  EXPECT_EQ(prim(pillar.children[1]).height, 4.2);
  EXPECT_EQ(prim(pillar.children[1]).radius, 0.25);
  EXPECT_EQ(pillar.children[2].transform.scale, Vec3(1.2, 0.6, 1.2));

  const Node& block = s.root.children[1];
  EXPECT_EQ(opType(block), OperatorType::Difference);
  EXPECT_EQ(prim(block.children[0]).type, PrimitiveType::Cube);
  EXPECT_EQ(prim(block.children[0]).b, Vec3(1.0));  // side is the half side
  EXPECT_EQ(prim(block.children[1]).type, PrimitiveType::Cylinder);

  const Node& copy = s.root.children[2];  // INSTANCE of node 1, moved by -4 in x
  EXPECT_EQ(copy.id, "9");
  EXPECT_EQ(copy.transform.translate, Vec3(-4.0, 0.0, 0.0));
  Node expected = pillar;
  expected.id = "9";
  expected.transform.translate = Vec3(-4.0, 0.0, 0.0);
  expectSameTree(expected, copy);

  const auto counts = countNodes(s.root);
  EXPECT_EQ(counts.primitives, 8u);
  EXPECT_EQ(counts.operators, 4u);
}

TEST(SceneBlob, EveryPrimitiveAndWarpWithOldSpellingsAndNulBytes) {
  const Scene s = loadScene(kData + "all_types.scene");
  EXPECT_EQ(opType(s.root), OperatorType::Blend);
  const auto& c = s.root.children;
  ASSERT_EQ(c.size(), 5u);

  EXPECT_EQ(warp(c[0]).type, WarpType::Twist);
  EXPECT_EQ(warp(c[0]).axis, 1);
  EXPECT_EQ(warp(c[0]).factor, 0.5);
  EXPECT_EQ(prim(c[0].children[0]).type, PrimitiveType::Line);  // SkeletonType=LINE
  EXPECT_EQ(prim(c[0].children[0]).b, Vec3(0.0, 2.0, 0.0));

  EXPECT_EQ(warp(c[1]).type, WarpType::Taper);
  EXPECT_EQ(warp(c[1]).axis, 2);
  EXPECT_EQ(warp(c[1]).otherAxis, 0);
  EXPECT_EQ(warp(c[1]).factor, -0.2);
  ASSERT_EQ(c[1].children.size(), 1u);  // (11, 99): the NULL is padding
  EXPECT_EQ(prim(c[1].children[0]).type, PrimitiveType::Ring);
  EXPECT_EQ(prim(c[1].children[0]).b, Vec3(0.0, 0.0, 1.0));  // direction normalised

  const Warp& bend = warp(c[2]);
  EXPECT_EQ(bend.type, WarpType::Bend);
  EXPECT_EQ(bend.axis, 1);
  EXPECT_EQ(bend.otherAxis, 2);
  EXPECT_EQ(bend.factor, 0.3);
  EXPECT_EQ(bend.centre, 1.0);
  EXPECT_EQ(bend.lo, -2.0);
  EXPECT_EQ(bend.hi, 3.0);
  EXPECT_EQ(prim(c[2].children[0]).type, PrimitiveType::Triangle);
  EXPECT_EQ(prim(c[2].children[0]).c, Vec3(0.0, 1.0, 0.0));

  EXPECT_EQ(warp(c[3]).type, WarpType::Shear);
  EXPECT_EQ(warp(c[3]).axis, 0);
  EXPECT_EQ(warp(c[3]).otherAxis, 1);
  const Primitive& quadric = prim(c[3].children[0]);
  EXPECT_EQ(quadric.type, PrimitiveType::QuadricPoint);
  EXPECT_EQ(quadric.scale, 2.5);    // thesis S
  EXPECT_EQ(quadric.support, 1.5);  // thesis R
  EXPECT_EQ(quadric.colour, Vec3(0.1, 0.2, 0.3));

  EXPECT_EQ(opType(c[4]), OperatorType::SmoothDifference);  // "smooth difference", lower case
  ASSERT_EQ(c[4].children.size(), 4u);
  EXPECT_EQ(prim(c[4].children[0]).b, Vec3(0.75));
  EXPECT_NEAR(c[4].children[0].transform.rotate.z, std::sqrt(0.5), 1e-7);  // (x, y, z, w) order
  EXPECT_NEAR(c[4].children[0].transform.rotate.w, std::sqrt(0.5), 1e-7);
  EXPECT_EQ(prim(c[4].children[2]).b, Vec3(1.0, 0.0, 0.0));
  EXPECT_EQ(c[4].children[3].transform.scale, Vec3(1.0, 2.0, 3.0));
  EXPECT_EQ(c[4].children[3].transform.translate, Vec3(4.0, 5.0, 6.0));
}

TEST(SceneBlob, SharedChildrenAreCopiedAndSeveralRootsAreUnited) {
  const Scene s = parseSceneBlob(R"([BLOBNODE a]
IsOperator=1
OperatorType=UNION
ChildrenIDs=(p, p)
[BLOBNODE p]
PrimitiveType=POINT
position=(1, 2, 3)
[BLOBNODE q]
PrimitiveType=POINT
[Global]
RootIDs=(a, q)
)", "mem.blob");
  EXPECT_EQ(opType(s.root), OperatorType::Union);
  ASSERT_EQ(s.root.children.size(), 2u);
  ASSERT_EQ(s.root.children[0].children.size(), 2u);
  expectSameTree(s.root.children[0].children[0], s.root.children[0].children[1]);
  EXPECT_EQ(s.root.children[1].id, "q");
}

// Numbers past double's range, as the JSON reader reads them: too small is the nearest double
// (zero keeps its sign), too large is out of the scene's range; neither is "not a number".
TEST(SceneBlob, NumbersBeyondDoubleReadLikeJson) {
  const auto scene = [](const std::string& x) {
    return "[BLOBNODE p]\nPrimitiveType=POINT\nposition=(" + x + ", 1e-310, 2)\n[Global]\nRootIDs=(p)\n";
  };
  const Scene s = parseSceneBlob(scene("-1e-400"), "tiny.blob");
  const Scene j = parseSceneJson(R"({"blobvk":1,"root":{"type":"point","centre":[-1e-400,1e-310,2]}})", "tiny.json");
  EXPECT_EQ(prim(s.root).a.x, 0.0);
  EXPECT_TRUE(std::signbit(prim(s.root).a.x));
  EXPECT_EQ(prim(s.root).a.y, 1e-310);
  EXPECT_EQ(prim(s.root).a.y, prim(j.root).a.y);
  try {
    parseSceneBlob(scene("1e400"), "huge.blob");
    FAIL() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("huge.blob: line 3: position: value 1e400 is out of range"), std::string::npos)
        << e.what();
  }
}

// A UTF-8 byte order mark before the first section (an editor on Windows) is not part of it.
TEST(SceneBlob, AByteOrderMarkIsSkipped) {
  const std::string text = "[BLOBNODE p]\nPrimitiveType=POINT\nposition=(1, 2, 3)\n[Global]\nRootIDs=(p)\n";
  const Scene plain = parseSceneBlob(text, "plain.blob"), marked = parseSceneBlob("\xEF\xBB\xBF" + text, "bom.blob");
  expectSameTree(plain.root, marked.root);
  EXPECT_THROW(parseSceneBlob("\xEF\xBB" + text, "half.blob"), SceneError);  // half a mark is not one
}

TEST(SceneBlob, DeepChainsAreRefusedWithALine) {
  std::string text;
  const int n = 5000;
  for (int i = 0; i < n; ++i)
    text += "[BLOBNODE " + std::to_string(i) + "]\nOperatorType=UNION\nChildrenIDs=(" + std::to_string(i + 1) + ")\n";
  text += "[BLOBNODE " + std::to_string(n) + "]\nPrimitiveType=POINT\n[Global]\nRootIDs=(0)\n";
  try {
    parseSceneBlob(text, "deep.blob");
    FAIL() << "expected a depth error";
  } catch (const SceneError& e) {
    EXPECT_NE(e.problem().find("deeper than 4096"), std::string::npos);
    EXPECT_EQ(e.location().rfind("line ", 0), 0u);
  }
}
