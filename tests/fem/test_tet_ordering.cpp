// fem::orderForLocality against properties that do not use its code: the renumbered mesh holds
// the same tets (as quadruples of positions, in the same orientation) with the same regions, the
// kept nodes keep their numbers, the boundary is the same triangles, and consecutive tets lie
// closer together than in a scrambled numbering of the same mesh.
#include "blobvk/fem/tet_ordering.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "icosphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <tuple>
#include <vector>

namespace blobvk::fem {
namespace {

using mesh::Double3;
using Corner = std::tuple<double, double, double>;

Corner corner(const Double3& p) { return {p.x, p.y, p.z}; }

// Each tet as its four rest positions, rotated to start at the smallest (an even permutation:
// the orientation is kept), with its region; sorted.
std::vector<std::pair<std::array<Corner, 4>, std::uint32_t>> tetsByPosition(const mesh::TetMesh& m) {
  std::vector<std::pair<std::array<Corner, 4>, std::uint32_t>> out;
  for (std::size_t t = 0; t < m.tetCount(); ++t) {
    std::array<Corner, 4> c;
    for (int k = 0; k < 4; ++k) c[k] = corner(m.restPositions[m.tets[t][k]]);
    // The even permutations that bring the smallest corner first.
    const int s = int(std::min_element(c.begin(), c.end()) - c.begin());
    static constexpr int kEven[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
    std::array<Corner, 4> r;
    for (int k = 0; k < 4; ++k) r[k] = c[kEven[s][k]];
    // Among the three cyclic turns of the last three corners (even), the smallest.
    std::array<Corner, 4> best = r;
    for (int turn = 1; turn < 3; ++turn) {
      std::rotate(r.begin() + 1, r.begin() + 2, r.end());
      best = std::min(best, r);
    }
    out.push_back({best, m.regions.empty() ? 0u : m.regions[t]});
  }
  std::sort(out.begin(), out.end());
  return out;
}

double meanStepBetweenTets(const mesh::TetMesh& m) {
  auto centroid = [&](std::size_t t) {
    Double3 c{};
    for (std::uint32_t n : m.tets[t]) c = {c.x + m.restPositions[n].x, c.y + m.restPositions[n].y, c.z + m.restPositions[n].z};
    return c;
  };
  double sum = 0;
  for (std::size_t t = 1; t < m.tetCount(); ++t) {
    const Double3 a = centroid(t - 1), b = centroid(t);
    sum += std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z)) / 4;
  }
  return sum / double(m.tetCount() - 1);
}

// A copy of `m` with tets and the nodes from `keep` on in a fixed pseudo-random order.
mesh::TetMesh scrambled(const mesh::TetMesh& m, std::size_t keep) {
  std::vector<std::uint32_t> nodes(m.nodeCount()), tets(m.tetCount());
  std::iota(nodes.begin(), nodes.end(), 0u);
  std::iota(tets.begin(), tets.end(), 0u);
  std::uint64_t state = 42;
  auto next = [&state](std::size_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return std::size_t((state >> 33) % n);
  };
  for (std::size_t i = m.nodeCount(); i-- > keep + 1;) std::swap(nodes[i], nodes[keep + next(i + 1 - keep)]);
  for (std::size_t i = m.tetCount(); i-- > 1;) std::swap(tets[i], tets[next(i + 1)]);
  mesh::TetMesh s;
  std::vector<std::uint32_t> newIndex(m.nodeCount());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    newIndex[nodes[i]] = std::uint32_t(i);
    s.positions.push_back(m.positions[nodes[i]]);
    s.restPositions.push_back(m.restPositions[nodes[i]]);
  }
  for (std::uint32_t t : tets) {
    s.tets.push_back({newIndex[m.tets[t][0]], newIndex[m.tets[t][1]], newIndex[m.tets[t][2]], newIndex[m.tets[t][3]]});
    s.regions.push_back(t % 3);  // regions to follow their tets
  }
  s.boundaryFaces = findBoundaryFaces(s);
  return s;
}

TEST(TetOrdering, KeepsTheMeshAndBringsNeighboursTogether) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  TetgenOptions o;
  o.maxVolume = 2e-3;
  const mesh::TriMesh sphere = testing::icosphere(2);
  const std::size_t keep = sphere.positions.size();
  mesh::TetMesh ball = tetrahedralize(sphere, o);
  // Deformed positions unlike the rest ones, so that both must move with their nodes.
  for (Double3& p : ball.positions) p = {p.x + 0.5 * p.y, p.y - 0.25 * p.z * p.z, p.z + 3.0};
  const mesh::TetMesh scrambledBall = scrambled(ball, keep);
  ASSERT_GT(scrambledBall.tetCount(), 1000u);
  mesh::TetMesh ordered = scrambledBall;
  orderForLocality(ordered, keep);

  ASSERT_EQ(ordered.nodeCount(), scrambledBall.nodeCount());
  for (std::size_t i = 0; i < keep; ++i) EXPECT_EQ(ordered.restPositions[i], scrambledBall.restPositions[i]) << i;
  // Each node's deformed position goes with its rest position (the deformation is a function of it).
  for (std::size_t i = 0; i < ordered.nodeCount(); ++i) {
    const Double3 r = ordered.restPositions[i], p = ordered.positions[i];
    EXPECT_EQ(p, (Double3{r.x + 0.5 * r.y, r.y - 0.25 * r.z * r.z, r.z + 3.0})) << "node " << i;
  }
  EXPECT_EQ(tetsByPosition(ordered), tetsByPosition(scrambledBall));
  EXPECT_NO_THROW(validateTetMesh(ordered));
  EXPECT_NEAR(totalVolume(ordered, true), totalVolume(scrambledBall, true), 1e-12);
  EXPECT_EQ(ordered.boundaryFaces, findBoundaryFaces(ordered));
  EXPECT_EQ(ordered.boundaryFaces.size(), scrambledBall.boundaryFaces.size());
  // The same boundary triangles, as positions (TetGen's quality pass adds boundary points too,
  // so not every boundary node is a kept one).
  auto facesByPosition = [](const mesh::TetMesh& m) {
    std::vector<std::array<Corner, 3>> out;
    for (const auto& f : m.boundaryFaces) {
      std::array<Corner, 3> c{corner(m.restPositions[f[0]]), corner(m.restPositions[f[1]]), corner(m.restPositions[f[2]])};
      std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());  // a turn keeps the orientation
      out.push_back(c);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(facesByPosition(ordered), facesByPosition(scrambledBall));
  const double before = meanStepBetweenTets(scrambledBall), after = meanStepBetweenTets(ordered);
  EXPECT_LT(after, 0.25 * before) << "consecutive tets " << after << " apart against " << before;
  // Interior nodes too: consecutive interior nodes closer than in the scrambled order.
  auto meanNodeStep = [keep](const mesh::TetMesh& m) {
    double sum = 0;
    for (std::size_t i = keep + 1; i < m.nodeCount(); ++i) {
      const Double3 p = m.restPositions[i - 1], q = m.restPositions[i];
      sum += std::sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (p.z - q.z) * (p.z - q.z));
    }
    return sum / double(m.nodeCount() - keep - 1);
  };
  EXPECT_LT(meanNodeStep(ordered), 0.25 * meanNodeStep(scrambledBall));
  // The same input gives the same numbering.
  mesh::TetMesh again = scrambledBall;
  orderForLocality(again, keep);
  EXPECT_EQ(again.tets, ordered.tets);
  EXPECT_EQ(again.regions, ordered.regions);
}

}  // namespace
}  // namespace blobvk::fem
