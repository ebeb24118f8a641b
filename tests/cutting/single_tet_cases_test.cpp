// Every cut case on single tets (or a tet pair for Z) at many positions and orientations: the
// split is conforming, the two sides end up separated across the cut, and volume is conserved.
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/predicates.h"
#include "blobvk/cutting/vec.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <optional>

namespace blobvk::cutting {
namespace {

struct Plane {
  Double3 point, normal;  // unit normal
};

Double3 normalized(Double3 v) { return v * (1.0 / length(v)); }

Double3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return normalized(Double3{g(rng), g(rng), g(rng)});
}

CutOptions thesisSnap() {
  CutOptions options;
  options.snapFraction = 0.2;
  return options;
}

// A plane giving each node the requested side (-1, 0 = through the node, +1), with every crossing
// of an edge between opposite sides at a fraction in [0.25, 0.75] (so nothing snaps with the
// thesis' snap fraction 0.2, which the cutters of these tests use: they test the cases, and a
// larger fraction would turn most of them into cuts through nodes).
std::optional<Plane> planeForPattern(const std::vector<Double3>& p, std::array<int, 4> pattern, std::mt19937& rng) {
  std::uniform_real_distribution<double> w(0.05, 1.0);
  std::vector<int> zeros;
  for (int i = 0; i < 4; ++i)
    if (pattern[i] == 0) zeros.push_back(i);
  const double scale = length(p[1] - p[0]);
  for (int attempt = 0; attempt < 20000; ++attempt) {
    Plane plane;
    if (zeros.empty()) {
      double ws[4], sum = 0;
      for (double& x : ws) sum += (x = w(rng));
      plane.point = (p[0] * ws[0] + p[1] * ws[1] + p[2] * ws[2] + p[3] * ws[3]) * (1.0 / sum);
      plane.normal = randomUnit(rng);
    } else if (zeros.size() == 1) {
      plane.point = p[zeros[0]];
      plane.normal = randomUnit(rng);
    } else if (zeros.size() == 2) {
      plane.point = p[zeros[0]];
      plane.normal = normalized(cross(p[zeros[1]] - p[zeros[0]], randomUnit(rng)));
    } else {
      plane.point = p[zeros[0]];
      plane.normal = normalized(cross(p[zeros[1]] - p[zeros[0]], p[zeros[2]] - p[zeros[0]]));
    }
    double s[4];
    for (int i = 0; i < 4; ++i) s[i] = pattern[i] == 0 ? 0.0 : dot(p[i] - plane.point, plane.normal);
    bool ok = true;
    int flip = 0;
    for (int i = 0; i < 4 && ok; ++i) {
      if (pattern[i] == 0) continue;
      if (std::fabs(s[i]) < 1e-3 * scale) ok = false;
      const int sign = s[i] > 0 ? 1 : -1;
      if (flip == 0) flip = sign * pattern[i];
      if (sign * pattern[i] != flip) ok = false;
    }
    for (int i = 0; i < 4 && ok; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (pattern[i] * pattern[j] < 0) {
          const double t = s[i] / (s[i] - s[j]);
          if (t < 0.25 || t > 0.75) ok = false;
        }
    if (ok) return plane;
  }
  return std::nullopt;
}

std::vector<Triangle> bigSquare(const Plane& plane, double half) {
  const Double3 u = normalized(cross(plane.normal, std::fabs(plane.normal.x) < 0.9 ? Double3{1, 0, 0} : Double3{0, 1, 0}));
  const Double3 v = cross(plane.normal, u);
  return test::squareTriangles(plane.point, u, v, half);
}

double diameter(const mesh::TetMesh& m) {
  double d = 0;
  for (const auto& a : m.positions)
    for (const auto& b : m.positions) d = std::max(d, length(a - b));
  return d;
}

// The parts after the cut: two, each entirely on one side of the plane. Crack nodes (those with
// a twin at the same rest position) are skipped: they lie on the cut, up to the snap distance.
void expectSeparatedByPlane(const CutTopology& topo, const Plane& plane, double scale) {
  const auto parts = disjointParts(topo);
  ASSERT_EQ(parts.size(), 2u);
  std::map<std::array<double, 3>, int> copies;
  for (const auto& r : topo.mesh().restPositions) ++copies[{r.x, r.y, r.z}];
  int sides[2] = {0, 0};
  for (int k = 0; k < 2; ++k)
    for (std::uint32_t slot : parts[k])
      for (std::uint32_t n : topo.tet(slot)) {
        const auto& r = topo.mesh().restPositions[n];
        if (copies[{r.x, r.y, r.z}] > 1) continue;
        const double s = dot(r - plane.point, plane.normal);
        if (std::fabs(s) <= 1e-9 * scale) continue;
        const int side = s > 0 ? 1 : -1;
        if (sides[k] == 0) sides[k] = side;
        EXPECT_EQ(side, sides[k]) << "part " << k << " straddles the cut";
      }
  EXPECT_EQ(sides[0] * sides[1], -1);
  // No node is shared by the two parts.
  std::vector<int> owner(topo.mesh().nodeCount(), -1);
  for (int k = 0; k < 2; ++k)
    for (std::uint32_t slot : parts[k])
      for (std::uint32_t n : topo.tet(slot)) {
        EXPECT_TRUE(owner[n] == -1 || owner[n] == k) << "node " << n << " shared across the crack";
        owner[n] = k;
      }
}

struct CaseSpec {
  CutCase kind;
  std::array<int, 4> pattern;
  int tets;
};

class CompleteCases : public ::testing::TestWithParam<CaseSpec> {};

TEST_P(CompleteCases, ConformingSeparatedAndVolumeConserving) {
  const CaseSpec spec = GetParam();
  std::mt19937 rng(1234 + int(spec.kind));
  int done = 0;
  for (int trial = 0; trial < 40; ++trial) {
    mesh::TetMesh m = test::randomTet(rng);
    // Permute which local node plays which role, so every code of the case is met.
    std::array<int, 4> pattern = spec.pattern;
    std::shuffle(pattern.begin(), pattern.end(), rng);
    const auto plane = planeForPattern(m.positions, pattern, rng);
    if (!plane) continue;
    const double scale = diameter(m);
    Cutter cutter(m, thesisSnap());
    const double before = cutter.topology().totalRestVolume();
    const CutResult r = cutter.cut(bigSquare(*plane, 10 * scale));
    EXPECT_EQ(r.count(spec.kind), 1u) << cutCaseName(spec.kind);
    EXPECT_EQ(cutter.topology().liveTetCount(), std::size_t(spec.tets));
    const SelfCheckReport check = cutter.topology().selfCheck();
    EXPECT_TRUE(check.ok()) << check.summary();
    EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), before), 1e-12);
    expectSeparatedByPlane(cutter.topology(), *plane, scale);
    ++done;
  }
  EXPECT_GE(done, 30);
}

INSTANTIATE_TEST_SUITE_P(Cases, CompleteCases,
                         ::testing::Values(CaseSpec{CutCase::A, {1, -1, -1, -1}, 4},
                                           CaseSpec{CutCase::B, {1, 1, -1, -1}, 6},
                                           CaseSpec{CutCase::X, {0, 1, -1, -1}, 3},
                                           CaseSpec{CutCase::Y, {0, 0, 1, -1}, 2}),
                         [](const auto& info) { return std::string(cutCaseName(info.param.kind)); });

TEST(CaseZ, CutAlongASharedFaceSeparatesTheTwoTets) {
  std::mt19937 rng(99);
  for (int trial = 0; trial < 40; ++trial) {
    mesh::TetMesh m = test::randomTet(rng);
    const auto& p = m.positions;
    const Double3 centre = (p[0] + p[1] + p[2]) * (1.0 / 3.0);
    m.positions.push_back(centre * 2.0 - p[3]);  // mirror of node 3 through the face centroid
    m.restPositions = m.positions;
    Tet second{0, 1, 2, 4};
    if (tetVolume(m.positions[0], m.positions[1], m.positions[2], m.positions[4]) < 0) std::swap(second[1], second[2]);
    m.tets.push_back(second);
    const Plane plane{centre, normalized(cross(p[1] - p[0], p[2] - p[0]))};
    Cutter cutter(m, thesisSnap());
    const double scale = diameter(m);
    const double before = cutter.topology().totalRestVolume();
    const CutResult r = cutter.cut(bigSquare(plane, 10 * scale));
    EXPECT_EQ(r.count(CutCase::Z), 2u);
    EXPECT_EQ(r.duplicatedNodes, 3u);
    EXPECT_TRUE(cutter.topology().selfCheck().ok());
    EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), before), 1e-12);
    expectSeparatedByPlane(cutter.topology(), plane, scale);
  }
}

// Partial cuts: the swept surface covers only some of the plane's crossings. The tet is split
// conformingly without separating; sweeping the rest of the plane then separates it.
enum class Partial { C, D, E };

class PartialCases : public ::testing::TestWithParam<Partial> {};

TEST_P(PartialCases, SplitWithoutSeparatingThenContinue) {
  const Partial kind = GetParam();
  std::mt19937 rng(77 + int(kind));
  int done = 0;
  for (int trial = 0; trial < 60 && done < 30; ++trial) {
    mesh::TetMesh m = test::randomTet(rng);
    const bool quad = kind == Partial::E;
    std::array<int, 4> pattern = quad ? std::array<int, 4>{1, 1, -1, -1} : std::array<int, 4>{1, -1, -1, -1};
    std::shuffle(pattern.begin(), pattern.end(), rng);
    const auto plane = planeForPattern(m.positions, pattern, rng);
    if (!plane) continue;
    std::vector<Double3> hits;  // crossings of the plane with the tet's edges
    const auto& p = m.positions;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (pattern[i] * pattern[j] < 0) {
          const double si = dot(p[i] - plane->point, plane->normal), sj = dot(p[j] - plane->point, plane->normal);
          hits.push_back(lerp(p[i], p[j], si / (si - sj)));
        }
    std::shuffle(hits.begin(), hits.end(), rng);
    Triangle tri;
    std::vector<Double3> outside;  // crossings the partial sweep must miss
    if (kind == Partial::C) {
      const double r = 0.2 * std::min(length(hits[1] - hits[0]), length(hits[2] - hits[0]));
      const Double3 u = normalized(hits[1] - hits[0]), v = cross(plane->normal, u);
      for (int k = 0; k < 3; ++k) {
        const double a = 2.0 * M_PI * k / 3.0;
        tri[k] = hits[0] + u * (r * std::cos(a)) + v * (r * std::sin(a));
      }
      outside = {hits[1], hits[2]};
    } else if (kind == Partial::D) {
      const Double3 d = hits[1] - hits[0];
      const Double3 w = normalized(cross(plane->normal, d)) * (0.05 * length(d));
      tri = {hits[0] - d * 0.1 + w, hits[0] - d * 0.1 - w, hits[1] + d * 0.1};
      outside = {hits[2]};
    } else {
      const Double3 c = (hits[0] + hits[1] + hits[2]) * (1.0 / 3.0);
      for (int k = 0; k < 3; ++k) tri[k] = c + (hits[k] - c) * 1.05;
      outside = {hits[3]};
    }
    const double scale = diameter(m);
    bool clear = true;
    for (const Double3& o : outside)
      if (length(o - closestPointOnTriangle(o, tri[0], tri[1], tri[2])) < 0.02 * scale) clear = false;
    if (!clear) continue;
    Cutter cutter(m, thesisSnap());
    const double before = cutter.topology().totalRestVolume();
    const CutResult r = cutter.cut({tri});
    const CutCase expected = kind == Partial::C ? CutCase::C : (kind == Partial::D ? CutCase::D : CutCase::E);
    EXPECT_EQ(r.count(expected), 1u);
    EXPECT_EQ(r.duplicatedNodes, 0u);
    EXPECT_GT(cutter.topology().liveTetCount(), 1u);
    EXPECT_TRUE(cutter.topology().selfCheck().ok());
    EXPECT_EQ(disjointParts(cutter.topology()).size(), 1u);  // the crack has not crossed the tet
    EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), before), 1e-12);
    // The blade moves on: the rest of the plane is swept and the tet comes apart.
    cutter.cut(bigSquare(*plane, 10 * scale));
    const SelfCheckReport check = cutter.topology().selfCheck();
    EXPECT_TRUE(check.ok()) << check.summary();
    EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), before), 1e-12);
    expectSeparatedByPlane(cutter.topology(), *plane, scale);
    ++done;
  }
  EXPECT_GE(done, 20);
}

INSTANTIATE_TEST_SUITE_P(Cases, PartialCases, ::testing::Values(Partial::C, Partial::D, Partial::E),
                         [](const auto& info) {
                           return std::string(info.param == Partial::C ? "C" : (info.param == Partial::D ? "D" : "E"));
                         });

}  // namespace
}  // namespace blobvk::cutting
