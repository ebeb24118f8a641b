// LocalFlips (local_flips.h): on hand-made configurations whose best connectivity is known, and on
// a TetGen ball of two regions where every tet below 40 deg is attacked. Oracles: the dihedral
// angles computed independently (tetQuality), the volume of each region and the boundary faces
// (unchanged by any flip), the self-check (conforming, positive), the change set replayed on a
// copy of the tets, and the minimum dihedral angle never falling.
#include "blobvk/cutting/local_flips.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/vec.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstdio>
#include <set>
#include <string>

namespace blobvk::cutting {
namespace {

double minAngle(const mesh::TetMesh& m) {
  double worst = 180;
  for (const auto& t : m.tets) {
    const auto& r = m.restPositions;
    worst = std::min(worst, tetQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]).minDihedralDeg);
  }
  return worst;
}

std::set<std::array<std::uint32_t, 3>> boundary(const CutTopology& topology) {
  std::set<std::array<std::uint32_t, 3>> faces;
  for (const auto& f : topology.toTetMesh().boundaryFaces) {
    std::array<std::uint32_t, 3> k{f[0], f[1], f[2]};
    std::sort(k.begin(), k.end());
    faces.insert(k);
  }
  return faces;
}

// The boundary as a surface: the faces are in `faces` or, where a boundary edge removal swapped
// the diagonal of a flat quad, each new face lies within the plane of an old face and has its
// centroid inside it; the total area is kept.
struct Surface {
  std::set<std::array<std::uint32_t, 3>> faces;
  double area = 0;
};
Surface surfaceOf(const CutTopology& topology) {
  Surface s;
  const auto& r = topology.mesh().restPositions;
  for (const auto& f : boundary(topology)) {
    s.faces.insert(f);
    s.area += 0.5 * length(cross(r[f[1]] - r[f[0]], r[f[2]] - r[f[0]]));
  }
  return s;
}
::testing::AssertionResult sameSurface(const Surface& before, const CutTopology& topology) {
  const Surface after = surfaceOf(topology);
  const auto& r = topology.mesh().restPositions;
  if (std::fabs(after.area - before.area) > 1e-12 * before.area)
    return ::testing::AssertionFailure() << "boundary area " << after.area << " != " << before.area;
  for (const auto& f : after.faces) {
    if (before.faces.count(f)) continue;
    const Double3 c = (r[f[0]] + r[f[1]] + r[f[2]]) * (1.0 / 3.0);
    bool covered = false;
    for (const auto& g : before.faces) {
      const Double3 a = r[g[0]], b = r[g[1]], d = r[g[2]];
      const Double3 n = cross(b - a, d - a);
      const double l = length(n);
      bool inPlane = true;
      for (std::uint32_t v : f) inPlane = inPlane && std::fabs(dot(r[v] - a, n)) <= 1e-9 * l * length(b - a);
      if (!inPlane) continue;
      // Barycentric signs of the centroid in g, within g's plane.
      const double u = dot(cross(d - b, c - b), n), v = dot(cross(a - d, c - d), n), w = dot(cross(b - a, c - a), n);
      if (u >= 0 && v >= 0 && w >= 0) covered = true;
    }
    if (!covered) return ::testing::AssertionFailure() << "new boundary face " << f[0] << " " << f[1] << " " << f[2] << " is off the old surface";
  }
  return ::testing::AssertionSuccess();
}

struct FlipRun {
  FlipStats stats;
  std::vector<std::uint32_t> removed, added;
  std::vector<Tet> removedNodes;
};

// Every tet below belowDeg attacked. `newSlots`: how many of the last slots count as appended in
// this event (new to the FEM: a 3-2 flip may give one back).
FlipRun improveAll(CutTopology& topology, double belowDeg, std::size_t newSlots = 0) {
  SpatialGrid grid;
  grid.rebuild(topology);
  std::vector<std::uint32_t> seeds(topology.slotCount());
  for (std::uint32_t s = 0; s < seeds.size(); ++s) seeds[s] = s;
  FlipRun run;
  LocalFlips flips;
  run.stats = flips.improve(topology, grid, seeds, belowDeg, 1u << 20, topology.slotCount() - newSlots,
                            {run.removed, run.removedNodes, run.added});
  return run;
}

TEST(LocalFlips, MinDihedralMatchesTetQuality) {
  const Double3 a{0, 0, 0}, b{1, 0.1, 0}, c{0.2, 1, 0.05}, d{0.3, 0.2, 0.9};
  EXPECT_NEAR(minDihedralDeg(a, b, c, d), tetQuality(a, b, c, d).minDihedralDeg, 1e-9);
  EXPECT_NEAR(minDihedralDeg({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}), 54.7356103172, 1e-8);
}

// A triangle (a, b, c) with apexes d above and e below, the triangle much larger than the apex
// heights: the two tets are flat, the three tets around the edge d-e are not.
TEST(LocalFlips, FaceRemovalReplacesTwoFlatTetsByThreeAroundTheApexEdge) {
  mesh::TetMesh m;
  m.positions = {{1, 0, 0}, {-0.5, 0.866, 0}, {-0.5, -0.866, 0}, {0, 0, 0.25}, {0, 0, -0.25}};
  m.restPositions = m.positions;
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  for (auto& t : m.tets)
    if (tetVolume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0) std::swap(t[0], t[1]);
  m.regions = {0, 0};
  const double before = minAngle(m);
  CutTopology topology(m);
  const auto faces = boundary(topology);
  const FlipRun run = improveAll(topology, 30);
  EXPECT_EQ(run.stats.faceRemovals, 1u);
  EXPECT_EQ(topology.liveTetCount(), 3u);
  EXPECT_TRUE(topology.hasEdge(3, 4));
  EXPECT_EQ(topology.tetsOfFace(0, 1, 2)[0], kNone);  // the shared face is gone
  EXPECT_TRUE(topology.selfCheck().ok());
  EXPECT_EQ(boundary(topology), faces);
  EXPECT_GT(minAngle(topology.toTetMesh()), before + 10);
}

// Edge removal on an octahedron: an axis (0, 0, +-h) through a ring of four nodes, the first at
// (s, 0, 0), the others at radius 1. The four tets around the axis or the four around either ring
// diagonal (the ring's two triangulations, valid when the tets do not overlap: their volumes sum
// to the octahedron's): the best of these, computed here with tetQuality, is what the flips must
// end with, and the axis must be gone exactly when a diagonal is better.
TEST(LocalFlips, EdgeRemovalEndsWithTheBestOfTheOctahedronsSplits) {
  int removed = 0;
  for (const double h : {0.3, 1.0, 2.0})
    for (const double s : {0.3, 0.6, 1.5, 2.5}) {
      mesh::TetMesh m;
      m.positions = {{0, 0, h}, {0, 0, -h}, {s, 0, 0}, {0, 1, 0}, {-1, 0, 0.01}, {0, -1, 0}};
      m.restPositions = m.positions;
      const auto& p = m.positions;
      std::vector<Tet> aroundAxis, aroundDiagonal02, aroundDiagonal13;
      for (std::uint32_t k = 0; k < 4; ++k) aroundAxis.push_back({0, 1, 2 + k, 2 + (k + 1) % 4});
      for (std::uint32_t apex : {0u, 1u}) {
        aroundDiagonal02.push_back({2, 3, 4, apex});
        aroundDiagonal02.push_back({2, 4, 5, apex});
        aroundDiagonal13.push_back({3, 4, 5, apex});
        aroundDiagonal13.push_back({3, 5, 2, apex});
      }
      auto volumeOf = [&](const std::vector<Tet>& tets) {
        double v = 0;
        for (const Tet& t : tets) v += std::fabs(tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]));
        return v;
      };
      const double volume = volumeOf(aroundAxis);
      auto worstOf = [&](const std::vector<Tet>& tets) {
        if (std::fabs(volumeOf(tets) - volume) > 1e-12 * volume) return -1.0;  // overlapping: not a split
        double worst = 180;
        for (const Tet& t : tets) worst = std::min(worst, tetQuality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]).minDihedralDeg);
        return worst;
      };
      const double axis = worstOf(aroundAxis);
      const double best = std::max({axis, worstOf(aroundDiagonal02), worstOf(aroundDiagonal13)});
      for (Tet& t : aroundAxis)
        if (tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
      m.tets = aroundAxis;
      m.regions.assign(4, 0);
      CutTopology topology(m);
      const auto faces = boundary(topology);
      const FlipRun run = improveAll(topology, 90);
      const std::string at = "h = " + std::to_string(h) + ", s = " + std::to_string(s);
      EXPECT_NEAR(minAngle(topology.toTetMesh()), best, 1e-9) << at;
      EXPECT_EQ(topology.hasEdge(0, 1), best == axis) << at;
      EXPECT_EQ(run.stats.edgeRemovals, best == axis ? 0u : 1u) << at;
      removed += best != axis;
      EXPECT_EQ(topology.liveTetCount(), 4u);
      EXPECT_TRUE(topology.selfCheck().ok()) << at;
      EXPECT_EQ(boundary(topology), faces) << at;
      EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-14 * volume) << at;
    }
  EXPECT_GT(removed, 0);  // some of these octahedra are better split along a ring diagonal
}

// The worst dihedral angle of some tets (tetQuality), or -1 when their volumes do not add up to
// `volume` (they overlap: not a split of the same union).
double worstSplit(const std::vector<Double3>& p, const std::vector<Tet>& tets, double volume) {
  double sum = 0, worst = 180;
  for (const Tet& t : tets) {
    sum += std::fabs(tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]));
    worst = std::min(worst, tetQuality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]).minDihedralDeg);
  }
  return std::fabs(sum - volume) > 1e-12 * volume ? -1.0 : worst;
}

void orient(const std::vector<Double3>& p, std::vector<Tet>& tets) {
  for (Tet& t : tets)
    if (tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
}

// A pyramid over the quad (a, c0, b, c2) in the plane z = 0 (a boundary face of the body), apex
// c1 above, in two tets around the boundary edge a-b. Its other split, around c0-c2, swaps the
// quad's diagonal within its plane: the flips must end with the better of the two (tetQuality),
// the boundary the same surface. With c2 lifted off the plane the two splits bound different
// surfaces: nothing may change, even where the other split would be better.
TEST(LocalFlips, BoundaryEdgeRemovalSwapsTheDiagonalOfAFlatQuad) {
  int swapped = 0, keptOffPlane = 0;  // cases where the other split is better
  for (const double lift : {0.0, 1e-3})
    for (const double w : {0.15, 0.4, 1.0, 2.5})
      for (const double h : {0.2, 0.8}) {
        mesh::TetMesh m;
        m.positions = {{-1, 0, 0}, {1, 0, 0}, {0.1, -w, 0}, {0.3, 0.2 * w, h}, {-0.1, 1.3 * w, lift}};
        m.restPositions = m.positions;
        const auto& p = m.positions;
        std::vector<Tet> aroundAB{{0, 1, 2, 3}, {0, 1, 3, 4}}, aroundC0C2{{2, 4, 3, 0}, {2, 4, 3, 1}};
        orient(p, aroundAB);
        orient(p, aroundC0C2);
        double volume = 0;
        for (const Tet& t : aroundAB) volume += tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
        const double ab = worstSplit(p, aroundAB, volume), other = worstSplit(p, aroundC0C2, volume);
        m.tets = aroundAB;
        m.regions.assign(2, 0);
        CutTopology topology(m);
        const auto faces = boundary(topology);
        const Surface surface = surfaceOf(topology);
        const FlipRun run = improveAll(topology, 90);
        const std::string at = "lift = " + std::to_string(lift) + ", w = " + std::to_string(w) + ", h = " + std::to_string(h);
        EXPECT_TRUE(topology.selfCheck().ok()) << at;
        EXPECT_EQ(topology.liveTetCount(), 2u) << at;
        EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-14 * volume) << at;
        // Where both splits share their worst angle (a face of the pyramid's side against the base)
        // neither is better: only the angle is checked.
        const bool better = other > ab + 1e-6;
        if (lift == 0) {
          EXPECT_NEAR(minAngle(topology.toTetMesh()), std::max(ab, other), 1e-9) << at;
          if (better || other < ab - 1e-6) {
            EXPECT_EQ(topology.hasEdge(0, 1), !better) << at;
            EXPECT_EQ(run.stats.boundaryEdgeRemovals, better ? 1u : 0u) << at;
          }
          EXPECT_TRUE(sameSurface(surface, topology)) << at;
          swapped += better;
        } else {
          EXPECT_EQ(run.stats.edgeRemovals, 0u) << at;
          EXPECT_EQ(boundary(topology), faces) << at;
          // Off the plane the other split bounds another volume; its angles alone would be better.
          double otherVolume = 0;
          for (const Tet& t : aroundC0C2) otherVolume += tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
          keptOffPlane += worstSplit(p, aroundC0C2, otherVolume) > ab + 1e-6;
        }
      }
  EXPECT_GT(swapped, 0);       // some quads are better split along c0-c2
  EXPECT_GT(keptOffPlane, 0);  // and some off the plane would have been too
}

// Three tets around the axis d-e of a bipyramid over the triangle (a, b, c), or two tets on
// either side of the triangle (the 3-2 flip). It frees a slot, so it is taken only when the last
// slot is new in this event (the FEM has not seen it): then the flips end with the better of the
// two splits (tetQuality) and the slot count drops to two; otherwise nothing changes.
TEST(LocalFlips, ThreeTwoFlipGivesBackTheEventsLastSlot) {
  int flipped = 0;
  for (const double h : {0.1, 0.3, 1.0, 3.0}) {
    mesh::TetMesh m;
    m.positions = {{1, 0, 0.02}, {-0.5, 0.866, 0}, {-0.45, -0.9, 0}, {0.05, 0, h}, {0, 0.05, -h}};
    m.restPositions = m.positions;
    const auto& p = m.positions;
    std::vector<Tet> aroundAxis{{3, 4, 0, 1}, {3, 4, 1, 2}, {3, 4, 2, 0}}, twoSides{{0, 1, 2, 3}, {0, 1, 2, 4}};
    orient(p, aroundAxis);
    orient(p, twoSides);
    double volume = 0;
    for (const Tet& t : aroundAxis) volume += tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
    const double axis = worstSplit(p, aroundAxis, volume), two = worstSplit(p, twoSides, volume);
    m.tets = aroundAxis;
    m.regions.assign(3, 0);
    const std::string at = "h = " + std::to_string(h);
    for (const std::size_t newSlots : {0u, 1u}) {
      CutTopology topology(m);
      const Surface surface = surfaceOf(topology);
      const FlipRun run = improveAll(topology, 90, newSlots);
      const bool flip = newSlots == 1 && two > axis;
      EXPECT_EQ(run.stats.threeTwo, flip ? 1u : 0u) << at;
      EXPECT_EQ(topology.slotCount(), flip ? 2u : 3u) << at;
      EXPECT_EQ(topology.hasEdge(3, 4), !flip) << at;
      EXPECT_NEAR(minAngle(topology.toTetMesh()), flip ? two : axis, 1e-9) << at;
      EXPECT_TRUE(topology.selfCheck().ok()) << at;
      EXPECT_TRUE(sameSurface(surface, topology)) << at;
      EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-14 * volume) << at;
      // The change set names only the slots the FEM keeps (the given-back one is not added).
      for (std::uint32_t s : run.added) EXPECT_LT(s, topology.slotCount()) << at;
      flipped += flip;
    }
  }
  EXPECT_GT(flipped, 0);
}

// Every tet of a TetGen ball below 40 deg attacked, with two regions (x < 0 and x >= 0 by
// centroid): no flip mixes them, so each region keeps its volume; the boundary (the ball's
// surface and the region interface are different things: only the surface is a boundary) is
// unchanged; the change set replays; the minimum angle does not fall.
TEST(LocalFlips, ManyFlipsKeepRegionsBoundaryVolumeAndReplay) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 4e-3;
  mesh::TetMesh m = fem::tetrahedralize(testing::icosphere(2), options);
  m.regions.assign(m.tets.size(), 0);
  for (std::size_t i = 0; i < m.tets.size(); ++i) {
    const auto& t = m.tets[i];
    const auto& p = m.restPositions;
    m.regions[i] = p[t[0]].x + p[t[1]].x + p[t[2]].x + p[t[3]].x < 0 ? 0u : 1u;
  }
  auto regionVolumes = [](const CutTopology& topology) {
    std::array<double, 2> v{};
    const auto& r = topology.mesh().restPositions;
    for (std::uint32_t s = 0; s < topology.slotCount(); ++s) {
      const Tet& t = topology.tet(s);
      v[topology.mesh().regions[s]] += tetVolume(r[t[0]], r[t[1]], r[t[2]], r[t[3]]);
    }
    return v;
  };
  const double before = minAngle(m);
  CutTopology topology(m);
  const Surface surface = surfaceOf(topology);
  const auto volumes = regionVolumes(topology);
  std::map<std::uint32_t, Tet> mirror;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s) mirror[s] = topology.tet(s);
  const FlipRun run = improveAll(topology, 40);
  EXPECT_GT(run.stats.edgeRemovals, 10u);
  EXPECT_GT(run.stats.threeTwo, 0u);  // after edge removals that appended slots
  EXPECT_GT(run.stats.boundaryEdgeRemovals, 0u);  // TetGen's Steiner points make flat pieces of the surface
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  EXPECT_TRUE(sameSurface(surface, topology));
  const auto after = regionVolumes(topology);
  for (int r = 0; r < 2; ++r) EXPECT_NEAR(after[r], volumes[r], 1e-13 * volumes[r]) << "region " << r;
  ASSERT_EQ(run.removed.size(), run.removedNodes.size());
  for (std::size_t i = 0; i < run.removed.size(); ++i) {
    ASSERT_EQ(mirror.at(run.removed[i]), run.removedNodes[i]);
    mirror.erase(run.removed[i]);
  }
  for (std::uint32_t s : run.added) mirror[s] = topology.tet(s);
  ASSERT_EQ(mirror.size(), topology.liveTetCount());
  for (const auto& [slot, nodes] : mirror) EXPECT_EQ(topology.tet(slot), nodes);
  const double improved = minAngle(topology.toTetMesh());
  EXPECT_GE(improved, before);
  std::printf("ball of %zu tets: %zu face removals, %zu edge removals (%zu 3-2, %zu on the boundary), min dihedral "
              "%.2f -> %.2f deg\n",
              m.tets.size(), run.stats.faceRemovals, run.stats.edgeRemovals, run.stats.threeTwo,
              run.stats.boundaryEdgeRemovals, before, improved);
}

}  // namespace
}  // namespace blobvk::cutting
