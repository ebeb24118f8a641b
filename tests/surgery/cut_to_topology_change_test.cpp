// surgery::toTopologyChange: every cut event of a blade moving through a falling, held ball is
// applied to a running fem::Simulation; after each one the simulation must hold the cutter's
// mesh (same nodes, tets slot by slot, rest positions and rest volume) and keep stepping finite.
// With node smoothing the events also move nodes at rest: the simulation must then carry each
// moved node to the cutter's rest position and, in the deformed body, to the cutter's position.
#include "blobvk/surgery/cut_to_topology_change.h"

#include "blobvk/cutting/blade.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/voxel_mesher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace {

using namespace blobvk;

mesh::TetMesh ball() {
  fem::VoxelMesherSettings voxel;
  voxel.boundsMin = {-1.1, -1.1, -1.1};
  voxel.boundsMax = {1.1, 1.1, 1.1};
  voxel.cellSize = 0.25;
  return fem::voxelTetrahedralize([](double x, double y, double z) { return x * x + y * y + z * z < 1.0 ? 1.0f : 0.0f; }, voxel);
}

// Whether a boundary face (the ball's surface or a crack face) passes through the node.
bool onTheBoundary(const cutting::CutTopology& topology, std::uint32_t node) {
  for (std::uint32_t slot : topology.tetsOfNode(node)) {
    const cutting::Tet& t = topology.tet(slot);
    for (const auto& face : cutting::kTetFaces) {
      const std::array<std::uint32_t, 3> f{t[std::size_t(face[0])], t[std::size_t(face[1])], t[std::size_t(face[2])]};
      if (std::find(f.begin(), f.end(), node) == f.end()) continue;
      const auto sides = topology.tetsOfFace(f[0], f[1], f[2]);
      if (sides[0] == cutting::kNone || sides[1] == cutting::kNone) return true;
    }
  }
  return false;
}

struct Moves {
  std::size_t all = 0, onBoundary = 0;  // nodes the events moved at rest; those on the boundary
};

Moves followTheCutter(double smoothBelowDeg) {
  const mesh::TetMesh rest = ball();
  EXPECT_GT(rest.tetCount(), 500u);
  // Six tets per kept voxel of edge 0.25: the volume every cut must conserve, computed from the
  // construction rather than by either module's sum.
  const double voxelVolume = double(rest.tetCount()) / 6.0 * 0.25 * 0.25 * 0.25;
  fem::SimulationSettings settings;
  settings.materials = {fem::Material{}};
  settings.materials[0].youngModulus = 5e4;
  settings.fixed = [](const mesh::Double3& p) { return p.y < -0.7; };  // held at the bottom
  fem::Simulation sim(rest, settings);
  cutting::CutOptions options;
  options.smoothBelowDeg = smoothBelowDeg;
  // The thesis' snap fraction: the blade, 0.2 edges from a plane of nodes, then splits tets and
  // leaves thin ones for the smoothing to move (the default 0.42 snaps the crack to that plane).
  options.snapFraction = 0.2;
  cutting::Cutter cutter(rest, options);
  Moves moved;

  // A vertical blade crossing the ball in x, moving in z: it cuts the ball in two halves.
  cutting::BladePath blade;
  for (int i = 0; i <= 8; ++i) blade.keyframes.push_back({0.02 * i, {0.05, 1.5, -1.5 + 3.0 * i / 8}, {0.05, -1.5, -1.5 + 3.0 * i / 8}});
  std::size_t changingEvents = 0;
  for (std::size_t i = 1; i < blade.keyframes.size(); ++i) {
    std::copy(sim.positions().begin(), sim.positions().end(), cutter.topology().positions().begin());
    cutter.positionsChanged();
    auto swept = cutting::sweptTriangles(blade.keyframes[i - 1], blade.keyframes[i]);
    if (i >= 2) {
      const auto previous = cutting::sweptTriangles(blade.keyframes[i - 2], blade.keyframes[i - 1]);
      swept.insert(swept.end(), previous.begin(), previous.end());
    }
    const std::size_t nodesBefore = sim.mesh().nodeCount(), tetsBefore = sim.mesh().tetCount();
    const cutting::CutResult event = cutter.cut(swept);
    sim.applyTopologyChange(surgery::toTopologyChange(event, cutter.topology(), nodesBefore, tetsBefore));
    changingEvents += !event.newNodes.empty();
    moved.all += event.movedNodes.size();
    for (const cutting::MovedNode& m : event.movedNodes) {  // moved in the deformed body too
      moved.onBoundary += onTheBoundary(cutter.topology(), m.index);
      const auto &a = sim.positions()[m.index], &b = cutter.topology().mesh().positions[m.index];
      EXPECT_NEAR(a.x, b.x, 1e-12);
      EXPECT_NEAR(a.y, b.y, 1e-12);
      EXPECT_NEAR(a.z, b.z, 1e-12);
    }

    const mesh::TetMesh& cut = cutter.topology().mesh();
    EXPECT_EQ(sim.mesh().nodeCount(), cut.nodeCount()) << "event " << i;
    EXPECT_EQ(sim.mesh().tetCount(), cutter.topology().liveTetCount()) << "event " << i;
    if (sim.mesh().nodeCount() != cut.nodeCount() || sim.mesh().tetCount() != cutter.topology().liveTetCount()) return moved;
    EXPECT_NEAR(sim.restVolume(), voxelVolume, 1e-9 * voxelVolume) << "event " << i;
    EXPECT_NEAR(cutter.topology().totalRestVolume(), voxelVolume, 1e-9 * voxelVolume) << "event " << i;
    for (std::size_t t = 0; t < cut.tetCount(); ++t) {
      EXPECT_EQ(sim.mesh().tets[t], cut.tets[t]) << "slot " << t;
      EXPECT_EQ(sim.mesh().regions.empty() ? 0u : sim.mesh().regions[t], cut.regions[t]) << "slot " << t;
    }
    for (std::size_t v = 0; v < cut.nodeCount(); ++v) {
      const auto &a = sim.mesh().restPositions[v], &b = cut.restPositions[v];
      EXPECT_NEAR(a.x, b.x, 1e-12);
      EXPECT_NEAR(a.y, b.y, 1e-12);
      EXPECT_NEAR(a.z, b.z, 1e-12);
    }
    EXPECT_TRUE(cutter.topology().selfCheck().ok()) << cutter.topology().selfCheck().summary();

    sim.run(2);  // the FEM keeps running on the cut mesh
    for (const auto& x : sim.positions()) EXPECT_TRUE(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z)) << "event " << i;
  }
  EXPECT_GT(changingEvents, 3u);
  // The blade went right through: two big halves (and maybe slivers the crack freed).
  const auto parts = cutting::disjointParts(cutter.topology());
  EXPECT_GE(parts.size(), 2u);
  if (parts.size() >= 2) {
    EXPECT_GT(parts[1].size(), sim.mesh().tetCount() / 4);
  }
  EXPECT_GT(sim.mesh().tetCount(), rest.tetCount());
  return moved;
}

TEST(CutToTopologyChange, TheSimulationFollowsTheCutterEventByEvent) { EXPECT_EQ(followTheCutter(0.0).all, 0u); }

TEST(CutToTopologyChange, TheSimulationFollowsNodesTheCutterMovesAtRest) {
  // Smoothing every written tet below 15 deg moves nodes (the count shows the test exercises it),
  // some of them sliding within the flat voxel faces of the ball's surface or the crack.
  const Moves moved = followTheCutter(15.0);
  std::printf("%zu nodes moved, %zu of them on the boundary\n", moved.all, moved.onBoundary);
  EXPECT_GT(moved.all, 5u);
  EXPECT_GT(moved.onBoundary, 0u);
}

TEST(CutToTopologyChange, AnEventItCannotExpressIsRefused) {
  const mesh::TetMesh rest = ball();
  const cutting::CutTopology topology(rest);
  cutting::CutResult removedOnly;  // a slot dropped and never refilled: the FEM has no removal
  removedOnly.removedTets = {3};
  removedOnly.removedTetNodes = {rest.tets[3]};
  EXPECT_THROW(surgery::toTopologyChange(removedOnly, topology, rest.nodeCount(), rest.tetCount()), std::logic_error);
  cutting::CutResult phantomNode;  // claims a new node the cutter does not have
  phantomNode.newNodes.push_back({});
  EXPECT_THROW(surgery::toTopologyChange(phantomNode, topology, rest.nodeCount(), rest.tetCount()), std::logic_error);
  // An event that changed nothing converts to an empty change.
  const fem::TopologyChange none = surgery::toTopologyChange(cutting::CutResult{}, topology, rest.nodeCount(), rest.tetCount());
  EXPECT_TRUE(none.newNodes.empty() && none.tetSlots.empty());
}

}  // namespace
