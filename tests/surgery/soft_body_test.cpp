// surgery::SoftBody: a body moving across a blade is cut through where the blade passed through
// its material; tools follow poses given at run time; fragments are removed or kept and
// reported; resection removes tets and the FEM goes on with the rest.
#include "test_bodies.h"

#include "blobvk/surgery/soft_body.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace {

using namespace blobvk;
using blobvk::testing::restCentroid;
using blobvk::testing::restVolume;
using blobvk::testing::voxelBox;

fem::SimulationSettings weightless() {
  fem::SimulationSettings s;
  s.gravity = {0, 0, 0};
  s.materials[0].youngModulus = 1e5;
  s.timeStep = 0.01;
  return s;
}

struct Extent {
  mesh::Double3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
};
Extent extentOf(const mesh::TetMesh& m) {
  Extent e;
  for (const auto& p : m.restPositions) {
    e.lo = {std::min(e.lo.x, p.x), std::min(e.lo.y, p.y), std::min(e.lo.z, p.z)};
    e.hi = {std::max(e.hi.x, p.x), std::max(e.hi.y, p.y), std::max(e.hi.z, p.z)};
  }
  return e;
}

double partVolume(const mesh::TetMesh& m, const std::vector<std::uint32_t>& part) {
  double v = 0;
  for (std::uint32_t t : part) v += restVolume(m, t);
  return v;
}

// The body drifts along +x at speed v while a vertical blade, fixed in x, sweeps along +z through
// it. In the body's material the blade passes x = x0 - v t(z): a slanted cut. Cutting where the
// blade is in the world against a body that has moved since the previous step (the old CLI)
// leaves a staircase of partial cuts; in material coordinates the strokes join and the body
// falls in two parts whose volumes the slanted plane predicts.
// With the blade mapped at its ends only, or at 4 segments' ends (the motion is rigid, so both
// map it exactly).
class MovingBody : public ::testing::TestWithParam<int> {};

TEST_P(MovingBody, IsCutThroughAlongTheMaterialTheBladePassed) {
  mesh::TetMesh box = voxelBox(0.5, 0.1);
  const Extent e = extentOf(box);
  const double v = 1.0, h = 0.01, x0 = 0.03, zStart = e.lo.z - 0.2, dz = 0.05;
  surgery::SoftBodyOptions options;
  options.fragments.action = surgery::FragmentPolicy::Action::Keep;
  options.checkEachEvent = true;
  options.bladeSegments = GetParam();
  surgery::SoftBody body(box, weightless(), options);
  std::vector<mesh::Double3> velocity(body.mesh().nodeCount(), {v, 0, 0});
  body.simulation().setVelocities(velocity);

  int steps = 0;
  for (double z = zStart; z <= e.hi.z + 0.2 + 1e-9; z += dz, ++steps) {
    surgery::StepInput in;
    in.blade.push_back({{x0, e.lo.y - 0.3, z}, {x0, e.hi.y + 0.3, z}});
    body.step(in);
  }
  body.step({});  // the blade is out: the stroke ends
  ASSERT_GT(steps, 10);
  // The body really moved across the blade during the stroke (several cells).
  EXPECT_GT(v * h * steps, 0.2);

  ASSERT_EQ(body.parts().size(), 2u);
  EXPECT_TRUE(body.fragments().empty());
  const mesh::TetMesh& m = body.mesh();
  const double total = partVolume(m, body.parts()[0]) + partVolume(m, body.parts()[1]);
  EXPECT_NEAR(total, (e.hi.x - e.lo.x) * (e.hi.y - e.lo.y) * (e.hi.z - e.lo.z), 1e-9);
  // The side of smaller x: at depth z the blade met material x_c(z) = x0 - v * t(z), t(z) the
  // time of the step that put the blade at z (it is mapped through the body at that step's start).
  const std::vector<std::uint32_t>& low = restCentroid(m, body.parts()[0][0]).x < restCentroid(m, body.parts()[1][0]).x
                                              ? body.parts()[0] : body.parts()[1];
  double expected = 0;
  const int samples = 2000;
  for (int i = 0; i < samples; ++i) {
    const double z = e.lo.z + (i + 0.5) * (e.hi.z - e.lo.z) / samples;
    const double t = (z - zStart) / dz * h;
    expected += std::clamp(x0 - v * t - e.lo.x, 0.0, e.hi.x - e.lo.x) * (e.hi.y - e.lo.y) * (e.hi.z - e.lo.z) / samples;
  }
  EXPECT_GT(expected, 0.3 * total);  // the slant matters: the cut is far from the plane x = x0
  EXPECT_LT(expected, 0.45 * total);
  // Cut points snap to nodes within 0.2 of an edge: the parts differ from the slanted plane by
  // less than a layer of cells.
  EXPECT_NEAR(partVolume(m, low), expected, 0.1 * (e.hi.y - e.lo.y) * (e.hi.z - e.lo.z));
  EXPECT_TRUE(body.topology().selfCheck().ok());
  EXPECT_GT(body.checksPassed(), 5u);
}

INSTANTIATE_TEST_SUITE_P(BladeSegments, MovingBody, ::testing::Values(1, 4));

// Tools follow the poses a host gives each step, not their keyframed paths.
TEST(SoftBody, ToolsFollowThePosesGivenAtRunTime) {
  fem::SimulationSettings settings = weightless();
  fem::Tool probe;
  probe.radius = 0.15;
  probe.stiffness = 1e4;
  probe.path = {{0, {5, 5, 5}, {1, 0, 0, 0}}};  // far away: the path alone never touches
  settings.tools = {probe};
  settings.fixedNodes = {0};
  surgery::SoftBody body(voxelBox(0.5, 0.1), settings);
  body.step({});
  EXPECT_EQ(body.simulation().toolContacts()[0].nodesInContact, 0u);
  surgery::StepInput in;
  fem::ToolPose pose;
  pose.position = {0, 0.6, 0};  // pressing on the top face
  in.tools = {pose};
  body.step(in);
  const fem::ToolContactReport& c = body.simulation().toolContacts()[0];
  EXPECT_GT(c.nodesInContact, 0u);
  EXPECT_LT(c.force.y, 0.0);  // the force on the body pushes it down, away from the tool
  in.tools = {fem::ToolPose{{5, 5, 5}, {1, 0, 0, 0, 1, 0, 0, 0, 1}}};
  body.step(in);
  EXPECT_EQ(body.simulation().toolContacts()[0].nodesInContact, 0u);
}

// A blade through one corner chips off a small piece: a fragment by the policy's size bound.
// Remove: it is resected (the body loses exactly its tets and volume) and reported; keep: it
// stays a part and is reported once.
TEST(SoftBody, FragmentsAreRemovedOrKeptAndReportedEitherWay) {
  const mesh::TetMesh box = voxelBox(0.5, 0.1);
  const Extent e = extentOf(box);
  double boxVolume = 0;
  for (std::uint32_t t = 0; t < box.tets.size(); ++t) boxVolume += restVolume(box, t);
  for (const auto action : {surgery::FragmentPolicy::Action::Remove, surgery::FragmentPolicy::Action::Keep}) {
    surgery::SoftBodyOptions options;
    options.fragments.action = action;
    options.fragments.maxFraction = 0.05;
    surgery::SoftBody body(box, weightless(), options);
    // A blade along the y axis sweeping the corner x + z > 0.8 (measured from the box corner).
    const double c = e.hi.x + e.hi.z - 0.17;  // plane x + z = c
    for (int k = 0; k <= 10; ++k) {
      const double y = e.lo.y - 0.2 + k * (e.hi.y - e.lo.y + 0.4) / 10;
      surgery::StepInput in;
      in.blade.push_back({{c - e.hi.z - 0.3, y, e.hi.z + 0.3}, {e.hi.x + 0.3, y, c - e.hi.x - 0.3}});
      in.endStroke = k == 10;
      body.step(in);
    }
    const auto fragments = body.fragments();
    ASSERT_EQ(fragments.size(), 1u) << (action == surgery::FragmentPolicy::Action::Keep ? "keep" : "remove");
    EXPECT_GT(fragments[0].tets, 0u);
    double volume = 0;
    for (const auto& part : body.parts()) volume += partVolume(body.mesh(), part);
    if (action == surgery::FragmentPolicy::Action::Remove) {
      EXPECT_TRUE(fragments[0].removed);
      ASSERT_EQ(body.parts().size(), 1u);
      EXPECT_EQ(body.mesh().tetCount(), body.parts()[0].size());
      // The chip's volume: the corner prism cut by the plane (0.17^2 / 2 times the height), within
      // the snapping of a cell layer.
      const double chip = 0.5 * 0.17 * 0.17 * (e.hi.y - e.lo.y);
      EXPECT_NEAR(boxVolume - volume, chip, 0.5 * chip);
      body.step({});
      for (const auto& p : body.simulation().positions()) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
    } else {
      EXPECT_FALSE(fragments[0].removed);
      EXPECT_EQ(body.parts().size(), 2u);
      EXPECT_NEAR(volume, boxVolume, 1e-9);
    }
  }
}

// Resection: the tets on one side are removed; the body keeps the rest, its state and its pins,
// and the nodes left without a tet are fixed.
TEST(SoftBody, ResectionRemovesTetsAndTheFemGoesOnWithTheRest) {
  fem::SimulationSettings settings = weightless();
  settings.gravity = {0, -9.81, 0};
  const mesh::TetMesh box = voxelBox(0.5, 0.1);
  settings.fixed = [](const mesh::Double3& p) { return p.y < -0.49; };
  surgery::SoftBody body(box, settings);
  for (int i = 0; i < 3; ++i) body.step({});
  std::vector<std::uint32_t> remove;
  double kept = 0;
  for (std::uint32_t t = 0; t < box.tets.size(); ++t) {
    if (restCentroid(box, t).x > 0.2) remove.push_back(t);
    else kept += restVolume(box, t);
  }
  const std::vector<mesh::Double3> before = body.simulation().positions();
  const double time = body.time();
  body.resect(remove);
  EXPECT_EQ(body.mesh().tetCount(), box.tets.size() - remove.size());
  EXPECT_NEAR(body.simulation().restVolume(), kept, 1e-9);
  EXPECT_EQ(body.simulation().positions(), before);
  EXPECT_DOUBLE_EQ(body.time(), time);
  std::vector<char> used(body.mesh().nodeCount(), 0);
  for (const auto& t : body.mesh().tets)
    for (auto v : t) used[v] = 1;
  for (std::uint32_t v = 0; v < used.size(); ++v) {
    if (!used[v]) {
      EXPECT_TRUE(body.simulation().fixedMask()[v]) << v;
    }
  }
  for (int i = 0; i < 3; ++i) body.step({});
  EXPECT_NEAR(body.time(), time + 0.03, 1e-12);
  for (const auto& p : body.simulation().positions()) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  EXPECT_THROW(body.resect({0, 0}), std::invalid_argument);
  EXPECT_THROW(body.resect({std::uint32_t(body.mesh().tetCount())}), std::invalid_argument);
}

}  // namespace
