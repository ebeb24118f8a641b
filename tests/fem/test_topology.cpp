// Simulation::applyTopologyChange: an incrementally edited simulation must match a fresh one
// built on the changed mesh with the same state; invalid changes throw and change nothing.
#include "cut_changes.h"
#include "blobvk/fem/node_incidence.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tet_utils.h"
#include "test_helpers.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

namespace blobvk::fem {
namespace {

using mesh::Double3;

SimulationSettings settings() {
  SimulationSettings s;
  s.materials = {Material{2e4, 0.4, 1000}, Material{8e4, 0.3, 1200}};
  s.fixed = [](const Double3& p) { return p.y < 1e-9; };
  s.cgTolerance = 0;  // a fixed number of CG iterations: both simulations do the same work
  s.cgMaxIterations = 40;
  s.rayleighMass = 0.1;
  return s;
}

mesh::TetMesh twoMaterialBox() {
  mesh::TetMesh m = test::boxMesh(0.3, 0.3, 0.3, 0.1);
  assignRegions(m, [](const Double3& c) { return c.x > 0.15 ? 1u : 0u; });
  return m;
}

// A simulation that has moved for a while (rotations and velocities are not trivial).
Simulation runningSimulation() {
  Simulation sim(twoMaterialBox(), settings());
  std::vector<Double3> v(sim.mesh().nodeCount());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = {0.3 * sim.mesh().restPositions[i].y, 0, -0.2 * sim.mesh().restPositions[i].x};
  sim.setVelocities(v);
  sim.run(10);
  return sim;
}

// Splits tets around two edges and cracks an interior node, as one change.
TopologyChange cutLikeChange(const mesh::TetMesh& m) {
  test::ChangeBuilder b(m);
  const auto& t0 = m.tets[40];
  b.splitEdge(t0[0], t0[1], 0.3);
  const auto& t1 = m.tets[100];
  b.splitEdge(t1[2], t1[3], 0.6);
  // The interior node nearest the centre, cracked along the plane x = its x.
  std::uint32_t centre = 0;
  double best = 1e9;
  for (std::uint32_t i = 0; i < m.nodeCount(); ++i) {
    const Double3& p = m.restPositions[i];
    const double d = std::abs(p.x - 0.1) + std::abs(p.y - 0.2) + std::abs(p.z - 0.1);
    if (d < best) best = d, centre = i;
  }
  const double cx = m.restPositions[centre].x;
  b.crack(centre, [&](std::size_t t) {
    double x = 0;
    for (auto v : b.tet(t)) x += v < m.nodeCount() ? m.restPositions[v].x : cx;
    return x / 4 > cx;
  });
  return b.build();
}

// A fresh simulation on sim's mesh and state (the reference the incremental edit must match).
Simulation freshCopy(const Simulation& sim) {
  mesh::TetMesh m = sim.mesh();
  m.boundaryFaces.clear();  // recomputed from scratch
  SimulationSettings s = sim.settings();
  for (std::uint32_t i = 0; i < sim.fixedMask().size(); ++i)
    if (sim.fixedMask()[i]) s.fixedNodes.push_back(i);
  Simulation fresh(std::move(m), s);
  fresh.setVelocities(sim.velocities());
  fresh.setPreviousVelocities(sim.previousVelocities());  // the warm start's history
  return fresh;
}

double relativeDifference(const std::vector<Double3>& a, const std::vector<Double3>& b) {
  double diff = 0, scale = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff = std::max({diff, std::abs(a[i].x - b[i].x), std::abs(a[i].y - b[i].y), std::abs(a[i].z - b[i].z)});
    scale = std::max({scale, std::abs(a[i].x), std::abs(a[i].y), std::abs(a[i].z)});
  }
  return diff / scale;
}

TEST(TopologyChange, IncrementalEditMatchesAFreshSimulation) {
  Simulation sim = runningSimulation();
  const std::size_t nodes = sim.mesh().nodeCount(), tets = sim.mesh().tetCount();
  const TopologyChange change = cutLikeChange(sim.mesh());
  ASSERT_EQ(change.newNodes.size(), 3u);
  sim.applyTopologyChange(change);
  EXPECT_EQ(sim.mesh().nodeCount(), nodes + 3);
  EXPECT_GT(sim.mesh().tetCount(), tets);

  Simulation fresh = freshCopy(sim);
  ASSERT_EQ(fresh.mesh().nodeCount(), sim.mesh().nodeCount());
  // The new nodes interpolate their sources (a split node lies on its edge, at the given weight).
  const NodeOrigin& o = change.newNodes[0];
  const Double3 a = sim.positions()[o.sources[0]], b = sim.positions()[o.sources[1]], m = sim.positions()[nodes];
  EXPECT_NEAR(m.x, 0.7 * a.x + 0.3 * b.x, 1e-15);
  EXPECT_EQ(sim.mesh().boundaryFaces, fresh.mesh().boundaryFaces);
  EXPECT_EQ(sim.fixedMask(), fresh.fixedMask());
  const auto &massA = sim.nodeMasses(), &massB = fresh.nodeMasses();
  for (std::size_t i = 0; i < massA.size(); ++i) EXPECT_NEAR(massA[i], massB[i], 1e-12 * massB[i]) << "node " << i;
  EXPECT_LT(relativeDifference(sim.elasticForces(), fresh.elasticForces()), 1e-10);
  EXPECT_NEAR(sim.energies().total(), fresh.energies().total(), 1e-10 * std::abs(fresh.energies().total()));
  sim.step();
  fresh.step();
  EXPECT_LT(relativeDifference(sim.positions(), fresh.positions()), 1e-10);
  EXPECT_LT(relativeDifference(sim.velocities(), fresh.velocities()), 1e-10);
  // Rest volume is conserved by splits and cracks.
  EXPECT_NEAR(sim.restVolume(), 0.027, 1e-12);
}

TEST(TopologyChange, ASlotWrittenTwiceKeepsItsLastVersion) {
  Simulation sim = runningSimulation();
  TopologyChange change = cutLikeChange(sim.mesh());
  // Write the first rewritten slot once more, before its final version, with another valid tet.
  const std::uint32_t slot = change.tetSlots.front();
  ASSERT_LT(slot, sim.mesh().tetCount());
  change.tetSlots.insert(change.tetSlots.begin(), slot);
  change.tetNodes.insert(change.tetNodes.begin(), sim.mesh().tets[(slot + 1) % sim.mesh().tetCount()]);
  change.tetRegions.insert(change.tetRegions.begin(), 1u);
  sim.applyTopologyChange(change);
  Simulation fresh = freshCopy(sim);
  EXPECT_EQ(sim.mesh().tets[slot], change.tetNodes[1]);
  EXPECT_EQ(sim.mesh().boundaryFaces, fresh.mesh().boundaryFaces);
  const auto &massA = sim.nodeMasses(), &massB = fresh.nodeMasses();
  for (std::size_t i = 0; i < massA.size(); ++i) EXPECT_NEAR(massA[i], massB[i], 1e-12 * massB[i]) << "node " << i;
  EXPECT_LT(relativeDifference(sim.elasticForces(), fresh.elasticForces()), 1e-10);
}

double signedVolume(const mesh::TetMesh& m, const std::array<std::uint32_t, 4>& t) {
  const auto &a = m.restPositions[t[0]], &b = m.restPositions[t[1]], &c = m.restPositions[t[2]], &d = m.restPositions[t[3]];
  const Double3 u{b.x - a.x, b.y - a.y, b.z - a.z}, v{c.x - a.x, c.y - a.y, c.z - a.z}, w{d.x - a.x, d.y - a.y, d.z - a.z};
  return (u.x * (v.y * w.z - v.z * w.y) - u.y * (v.x * w.z - v.z * w.x) + u.z * (v.x * w.y - v.y * w.x)) / 6.0;
}

// A 2-3 flip: two tets sharing face (a, b, c), with apexes d and e, become three tets around
// edge d-e (where that is a valid split of their union). The new faces join old nodes only and
// no removed tet had them, and the pair's outer faces change users: the boundary update must
// count those faces, not infer them. The pair is one with an outer face on the boundary. Interior
// nodes are jittered: on the regular grid every such pair is degenerate (d-e meets an edge).
TEST(TopologyChange, AFlipBetweenOldNodesMatchesAFreshSimulation) {
  mesh::TetMesh jittered = twoMaterialBox();
  for (std::size_t i = 0; i < jittered.nodeCount(); ++i) {
    Double3& p = jittered.restPositions[i];
    const bool inside = p.x > 1e-9 && p.x < 0.3 - 1e-9 && p.y > 1e-9 && p.y < 0.3 - 1e-9 && p.z > 1e-9 && p.z < 0.3 - 1e-9;
    if (!inside) continue;
    const double j = 0.015 * std::sin(12.9898 * double(i)), k = 0.015 * std::cos(78.233 * double(i));
    p = {p.x + j, p.y + k, p.z + 0.5 * (j - k)};
    jittered.positions[i] = p;
  }
  Simulation sim(jittered, settings());
  sim.run(5);
  const mesh::TetMesh& m = sim.mesh();
  std::set<std::array<std::uint32_t, 3>> boundary;
  for (auto f : m.boundaryFaces) {
    std::sort(f.begin(), f.end());
    boundary.insert(f);
  }
  std::optional<TopologyChange> flip;
  for (std::uint32_t s1 = 0; s1 < m.tetCount() && !flip; ++s1)
    for (std::uint32_t s2 = s1 + 1; s2 < m.tetCount() && !flip; ++s2) {
      const auto &t1 = m.tets[s1], &t2 = m.tets[s2];
      std::vector<std::uint32_t> shared, apex;
      for (auto v : t1) (std::find(t2.begin(), t2.end(), v) != t2.end() ? shared : apex).push_back(v);
      if (shared.size() != 3) continue;
      for (auto v : t2)
        if (std::find(t1.begin(), t1.end(), v) == t1.end()) apex.push_back(v);
      TopologyChange c;
      double volume = 0;
      bool outerOnBoundary = false;
      for (int k = 0; k < 3; ++k) {
        std::array<std::uint32_t, 4> t{shared[std::size_t(k)], shared[std::size_t(k + 1) % 3], apex[0], apex[1]};
        if (signedVolume(m, t) < 0) std::swap(t[0], t[1]);
        t = {t[3], t[1], t[0], t[2]};  // an even permutation: other corners, so other face rotations
        volume += signedVolume(m, t);
        if (!(signedVolume(m, t) > 1e-9)) break;
        for (auto d : {apex[0], apex[1]}) {
          std::array<std::uint32_t, 3> outer{shared[std::size_t(k)], shared[std::size_t(k + 1) % 3], d};
          std::sort(outer.begin(), outer.end());
          outerOnBoundary = outerOnBoundary || boundary.count(outer) > 0;
        }
        c.tetSlots.push_back(k == 0 ? s1 : k == 1 ? s2 : std::uint32_t(m.tetCount()));
        c.tetNodes.push_back(t);
        c.tetRegions.push_back(m.regions[s1]);
      }
      const double before = signedVolume(m, t1) + signedVolume(m, t2);
      if (c.tetSlots.size() == 3 && outerOnBoundary && std::abs(volume - before) < 1e-12 * before) flip = c;
    }
  ASSERT_TRUE(flip.has_value());
  sim.applyTopologyChange(*flip);
  Simulation fresh = freshCopy(sim);
  EXPECT_EQ(sim.mesh().boundaryFaces, fresh.mesh().boundaryFaces);
  const auto &massA = sim.nodeMasses(), &massB = fresh.nodeMasses();
  for (std::size_t i = 0; i < massA.size(); ++i) EXPECT_NEAR(massA[i], massB[i], 1e-12 * massB[i]) << "node " << i;
  EXPECT_LT(relativeDifference(sim.elasticForces(), fresh.elasticForces()), 1e-10);
  EXPECT_NEAR(sim.restVolume(), 0.027, 1e-12);
}

// A node moved at rest (a cut's node smoothing): its new rest position, position and velocity are
// the weighted sums of the tet that holds the new place, and the tets around it change their rest
// shape. Oracles: the sums computed here, and a fresh simulation on the changed mesh and state.
TEST(TopologyChange, ANodeMovedAtRestMatchesAFreshSimulation) {
  Simulation sim = runningSimulation();
  const mesh::TetMesh& m = sim.mesh();
  // The free interior node nearest (0.1, 0.2, 0.1), moved towards the centroid of its first tet.
  std::uint32_t node = 0;
  double best = 1e9;
  for (std::uint32_t i = 0; i < m.nodeCount(); ++i) {
    const Double3& p = m.restPositions[i];
    const double d = std::abs(p.x - 0.1) + std::abs(p.y - 0.2) + std::abs(p.z - 0.1);
    if (d < best && !sim.fixedMask()[i]) best = d, node = i;
  }
  std::vector<std::uint32_t> star;
  for (std::uint32_t t = 0; t < m.tetCount(); ++t)
    if (std::find(m.tets[t].begin(), m.tets[t].end(), node) != m.tets[t].end()) star.push_back(t);
  ASSERT_GE(star.size(), 4u);
  const auto holder = m.tets[star[0]];
  NodeMove move;
  move.node = node;
  move.origin.sources = holder;
  for (std::size_t i = 0; i < 4; ++i) move.origin.weights[i] = holder[i] == node ? 0.7 : 0.1;
  Double3 rest{}, pos{}, vel{};
  for (std::size_t i = 0; i < 4; ++i) {
    const double w = move.origin.weights[i];
    const std::uint32_t v = holder[i];
    rest = {rest.x + w * m.restPositions[v].x, rest.y + w * m.restPositions[v].y, rest.z + w * m.restPositions[v].z};
    pos = {pos.x + w * m.positions[v].x, pos.y + w * m.positions[v].y, pos.z + w * m.positions[v].z};
    vel = {vel.x + w * sim.velocities()[v].x, vel.y + w * sim.velocities()[v].y, vel.z + w * sim.velocities()[v].z};
  }
  TopologyChange change;
  change.movedNodes.push_back(move);
  for (std::uint32_t t : star) {
    change.tetSlots.push_back(t);
    change.tetNodes.push_back(m.tets[t]);
    change.tetRegions.push_back(m.regions[t]);
  }
  // Leaving a tet of the star out is refused (its rest shape would be stale), and changes nothing.
  TopologyChange partial = change;
  partial.tetSlots.pop_back(), partial.tetNodes.pop_back(), partial.tetRegions.pop_back();
  const Double3 restBefore = m.restPositions[node];
  EXPECT_THROW(sim.applyTopologyChange(partial), std::invalid_argument);
  EXPECT_EQ(sim.mesh().restPositions[node].x, restBefore.x);

  const std::vector<Double3> forcesBefore = sim.elasticForces();
  sim.applyTopologyChange(change);
  EXPECT_EQ(sim.mesh().restPositions[node].x, rest.x);
  EXPECT_EQ(sim.mesh().restPositions[node].y, rest.y);
  EXPECT_EQ(sim.mesh().restPositions[node].z, rest.z);
  EXPECT_EQ(sim.positions()[node].x, pos.x);
  EXPECT_EQ(sim.velocities()[node].z, vel.z);
  EXPECT_GT(relativeDifference(sim.elasticForces(), forcesBefore), 1e-6);  // the rest shape did change
  Simulation fresh = freshCopy(sim);
  EXPECT_EQ(sim.mesh().boundaryFaces, fresh.mesh().boundaryFaces);
  const auto &massA = sim.nodeMasses(), &massB = fresh.nodeMasses();
  for (std::size_t i = 0; i < massA.size(); ++i) EXPECT_NEAR(massA[i], massB[i], 1e-12 * massB[i]) << "node " << i;
  EXPECT_LT(relativeDifference(sim.elasticForces(), fresh.elasticForces()), 1e-10);
  sim.step();
  fresh.step();
  EXPECT_LT(relativeDifference(sim.positions(), fresh.positions()), 1e-10);
  EXPECT_NEAR(sim.restVolume(), 0.027, 1e-12);  // the node stayed inside its star
}

TEST(TopologyChange, InvalidChangesThrowAndLeaveTheSimulationUnchanged) {
  Simulation sim = runningSimulation();
  const mesh::TetMesh before = sim.mesh();
  const std::vector<double> masses = sim.nodeMasses();
  const std::vector<Double3> forces = sim.elasticForces();
  const TopologyChange good = cutLikeChange(sim.mesh());
  auto expectRejected = [&](TopologyChange c, const char* what) {
    try {
      sim.applyTopologyChange(c);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
    EXPECT_EQ(sim.mesh().tets, before.tets);
    EXPECT_EQ(sim.mesh().nodeCount(), before.nodeCount());
    EXPECT_EQ(sim.mesh().boundaryFaces, before.boundaryFaces);
    EXPECT_EQ(sim.nodeMasses(), masses);
  };
  TopologyChange c = good;
  c.tetSlots.back() = std::uint32_t(before.tetCount() + 1000);
  expectRejected(c, "past the end");
  c = good;
  c.tetNodes.back()[2] = std::uint32_t(before.nodeCount() + 50);
  expectRejected(c, "references node");
  c = good;
  std::swap(c.tetNodes.front()[0], c.tetNodes.front()[1]);
  expectRejected(c, "non-positive rest volume");
  c = good;
  c.tetRegions.back() = 7;
  expectRejected(c, "without a material");
  c = good;
  c.newNodes[0].sources = {kNoSource, kNoSource, kNoSource, kNoSource};
  expectRejected(c, "no source");
  EXPECT_LT(relativeDifference(sim.elasticForces(), forces), 1e-12);
  sim.applyTopologyChange(good);  // the valid change still applies afterwards
  EXPECT_EQ(sim.mesh().nodeCount(), before.nodeCount() + 3);
}

TEST(TopologyChange, SequenceOfCutsUnderAPressingToolStaysFinite) {
  SimulationSettings s = settings();
  s.cgTolerance = 1e-6;
  s.cgMaxIterations = 100;
  Tool tool;
  tool.radius = 0.05;
  tool.stiffness = 5e3;
  tool.path = {{0.0, {0.1, 0.36, 0.1}, {1, 0, 0, 0}}, {1.0, {0.1, 0.29, 0.1}, {1, 0, 0, 0}}};  // over a node
  s.tools = {tool};
  Simulation sim(twoMaterialBox(), s);
  std::size_t contactSteps = 0;
  for (int i = 0; i < 200; ++i) {
    if (i % 40 == 10) {  // a cut every 40 steps, on the current mesh
      test::ChangeBuilder b(sim.mesh());
      const auto& t = sim.mesh().tets[std::size_t(17 * i) % sim.mesh().tetCount()];
      b.splitEdge(t[0], t[3], 0.4);
      const std::uint32_t node = t[1];
      const double x = sim.mesh().restPositions[node].x;
      b.crack(node, [&](std::size_t k) {
        double cx = 0;
        for (auto v : b.tet(k)) cx += v < sim.mesh().nodeCount() ? sim.mesh().restPositions[v].x : x;
        return cx / 4 > x;
      });
      sim.applyTopologyChange(b.build());
    }
    sim.step();
    if (sim.toolContacts()[0].nodesInContact > 0) ++contactSteps;
    for (const auto& p : sim.positions()) ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << "step " << i;
  }
  EXPECT_GT(contactSteps, 100u);
  EXPECT_GT(sim.mesh().nodeCount(), twoMaterialBox().nodeCount() + 5);
  EXPECT_EQ(sim.mesh().boundaryFaces, freshCopy(sim).mesh().boundaryFaces);
}

// Rows that outgrow their room move to the end of the storage, several times; the rows must
// always equal those of a fresh build of the same tets.
TEST(NodeIncidence, EditedRowsEqualAFreshBuildThroughRowMoves) {
  std::vector<std::array<std::uint32_t, 4>> tets;
  for (std::uint32_t k = 0; k < 50; ++k) tets.push_back({k, k + 1, k + 2, k + 3});
  NodeIncidence incidence;
  incidence.build(60, tets);
  incidence.addNodes(3);  // nodes 60..62 start empty with little room
  for (std::uint32_t round = 0; round < 40; ++round) {
    const std::uint32_t t = (round * 7) % 50;
    const std::array<std::uint32_t, 4> next{60 + round % 3, t, (t + 5) % 60, (t + 9) % 60};
    if (round % 2 == 0) {
      incidence.removeTet(t, tets[t]);
      incidence.addTet(t, next);
    } else {
      incidence.replaceTet(t, tets[t], next);  // nodes kept in both versions move corners in place
    }
    tets[t] = next;
    tets.push_back({60, 61, 62, round});  // appended: rows 60..62 grow well past their room
    incidence.addTet(std::uint32_t(tets.size() - 1), tets.back());
  }
  NodeIncidence fresh;
  fresh.build(63, tets);
  for (std::size_t v = 0; v < 63; ++v) {
    const std::vector<std::uint32_t> a(incidence.begin(v), incidence.end(v)), b(fresh.begin(v), fresh.end(v));
    EXPECT_EQ(a, b) << "node " << v;
  }
  EXPECT_GT(incidence.count(60), 40u);
  EXPECT_THROW(incidence.removeTet(0, {59, 58, 57, 56}), std::logic_error);
}

// The per-tet passes and per-node gathers must give bit-identical results on 1 and on all threads.
TEST(Determinism, StepsAndCutsDoNotDependOnTheThreadCount) {
  auto run = [] {
    SimulationSettings s = settings();
    Tool tool;
    tool.radius = 0.05;
    tool.stiffness = 5e3;
    tool.path = {{0.0, {0.1, 0.36, 0.1}, {1, 0, 0, 0}}, {0.5, {0.1, 0.28, 0.1}, {1, 0, 0, 0}}};
    s.tools = {tool};
    Simulation sim(test::boxMesh(0.3, 0.3, 0.6, 0.05), s);  // 2,592 tets: several parallel chunks
    sim.run(15);
    sim.applyTopologyChange(cutLikeChange(sim.mesh()));
    sim.run(15);
    return sim.positions();
  };
  std::vector<Double3> serial;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial = run();
  }
  const std::vector<Double3> parallel = run();
  ASSERT_EQ(serial.size(), parallel.size());
  for (std::size_t i = 0; i < serial.size(); ++i) {
    ASSERT_EQ(serial[i].x, parallel[i].x) << "node " << i;
    ASSERT_EQ(serial[i].y, parallel[i].y) << "node " << i;
    ASSERT_EQ(serial[i].z, parallel[i].z) << "node " << i;
  }
}

}  // namespace
}  // namespace blobvk::fem
