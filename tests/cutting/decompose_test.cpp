// The sub-element "tables", checked exhaustively: every cut code allowed after filtering, every
// order of vertex keys, many cut parameters.
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/decompose.h"
#include "blobvk/cutting/topology.h"
#include "blobvk/cutting/vec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <map>
#include <random>

namespace blobvk::cutting {
namespace {

bool validMasks(int edgeMask, int nodeMask) {
  for (int e = 0; e < 6; ++e)
    if ((edgeMask >> e & 1) && ((nodeMask >> kTetEdges[e][0] & 1) || (nodeMask >> kTetEdges[e][1] & 1))) return false;
  return true;
}

TEST(Decompose, ThesisCodesClassify) {
  EXPECT_EQ(caseAEdgeCode(0), 56);
  EXPECT_EQ(caseAEdgeCode(1), 37);
  EXPECT_EQ(caseAEdgeCode(2), 11);
  EXPECT_EQ(caseAEdgeCode(3), 22);
  for (int node = 0; node < 4; ++node) EXPECT_EQ(classifyCut(caseAEdgeCode(node), 0), CutCase::A);
  for (int code : {46, 51, 29}) EXPECT_EQ(classifyCut(std::uint8_t(code), 0), CutCase::B);
  for (int e = 0; e < 6; ++e) EXPECT_EQ(classifyCut(std::uint8_t(1 << e), 0), CutCase::C);
  EXPECT_EQ(classifyCut(0b000011, 0), CutCase::D);  // e0, e1 share node 2
  EXPECT_EQ(classifyCut(0b010001, 0), CutCase::D);  // e0, e4 opposite
  EXPECT_EQ(classifyCut(0b000111, 0), CutCase::E);  // face f0's three edges
  // X: node 0 a cut node, edges e0 (1-2) and e2 (3-1) cut: node 1 separated from 2, 3.
  EXPECT_EQ(classifyCut(0b000101, 0b0001), CutCase::X);
  EXPECT_EQ(classifyCut(0b000001, 0b1001), CutCase::Y);  // nodes 0, 3 and edge 1-2
  EXPECT_EQ(classifyCut(0, 0b0111), CutCase::Z);
  EXPECT_EQ(classifyCut(0, 0b0011), CutCase::NodesOnly);
  EXPECT_EQ(classifyCut(0, 0), CutCase::Untouched);
  EXPECT_THROW(decomposeTet(0b100000, 0b0001, {}), std::invalid_argument);  // e5 touches node 0
}

TEST(Decompose, EveryCodeEveryKeyOrderIsAValidConformingSplit) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> param(0.05, 0.95);
  const std::array<Double3, 4> corner{Double3{0.1, -0.3, 0.2}, Double3{1.3, 0.1, -0.2}, Double3{0.2, 1.1, 0.3},
                                      Double3{0.4, 0.2, 1.4}};
  const double parentVolume = tetVolume(corner[0], corner[1], corner[2], corner[3]);
  ASSERT_GT(parentVolume, 0);
  std::map<CutCase, int> expectedCount{{CutCase::A, 4}, {CutCase::B, 6}, {CutCase::X, 3}, {CutCase::Y, 2}};
  std::map<CutCase, int> seen;
  for (int nodeMask = 0; nodeMask < 16; ++nodeMask)
    for (int edgeMask = 0; edgeMask < 64; ++edgeMask) {
      if (!validMasks(edgeMask, nodeMask)) continue;
      std::array<int, 4> perm{0, 1, 2, 3};
      do {
        std::array<std::uint64_t, 11> keys{};
        for (int i = 0; i < 4; ++i) keys[i] = std::uint64_t(perm[i]);
        std::array<int, 6> edgeOrder{0, 1, 2, 3, 4, 5};
        std::shuffle(edgeOrder.begin(), edgeOrder.end(), rng);
        for (int e = 0; e < 6; ++e) keys[kEdgePointBase + e] = 10 + std::uint64_t(edgeOrder[e]);
        keys[kSteinerLocal] = 100;
        const Decomposition d = decomposeTet(std::uint8_t(edgeMask), std::uint8_t(nodeMask), keys);
        ++seen[d.kind];
        if (expectedCount.count(d.kind)) {
          EXPECT_EQ(d.tetCount, expectedCount[d.kind]) << cutCaseName(d.kind);
        }
        EXPECT_EQ(d.separating, d.kind == CutCase::A || d.kind == CutCase::B || d.kind == CutCase::X ||
                                    d.kind == CutCase::Y);
        for (int sample = 0; sample < 3; ++sample) {
          std::array<Double3, 11> p{};
          for (int i = 0; i < 4; ++i) p[i] = corner[i];
          for (int e = 0; e < 6; ++e)
            p[kEdgePointBase + e] = lerp(corner[kTetEdges[e][0]], corner[kTetEdges[e][1]], param(rng));
          p[kSteinerLocal] = (corner[0] + corner[1] + corner[2] + corner[3]) * 0.25;
          double sum = 0;
          // Faces: interior ones used twice in opposite directions, the rest lie on the parent.
          std::map<std::array<int, 3>, std::vector<std::array<int, 3>>> faces;
          for (int i = 0; i < d.tetCount; ++i) {
            const auto& c = d.tets[i];
            const double v = tetVolume(p[c[0]], p[c[1]], p[c[2]], p[c[3]]);
            EXPECT_GT(v, 0) << "edge " << edgeMask << " node " << nodeMask;
            sum += v;
            for (const auto& f : kTetFaces) {
              std::array<int, 3> key{c[f[0]], c[f[1]], c[f[2]]}, sorted = key;
              std::sort(sorted.begin(), sorted.end());
              faces[sorted].push_back(key);
            }
          }
          EXPECT_NEAR(sum / parentVolume, 1.0, 1e-12);
          for (const auto& [key, uses] : faces) {
            ASSERT_LE(uses.size(), 2u);
            if (uses.size() == 2) continue;
            // A single-use face must lie on one of the parent's faces: all three vertices on it.
            bool onParentFace = false;
            for (const auto& f : kTetFaces) {
              bool all = true;
              for (int v : key)
                if (std::fabs(tetVolume(corner[f[0]], corner[f[1]], corner[f[2]], p[v])) > 1e-12) all = false;
              onParentFace |= all;
            }
            EXPECT_TRUE(onParentFace);
          }
          // Crack triangles are interior faces with the two sides on either side.
          for (int i = 0; i < d.crackCount; ++i) {
            std::array<int, 3> sorted{d.crack[i][0], d.crack[i][1], d.crack[i][2]};
            std::sort(sorted.begin(), sorted.end());
            EXPECT_EQ(faces[sorted].size(), 2u);
          }
        }
      } while (std::next_permutation(perm.begin(), perm.end()));
    }
  for (CutCase c : {CutCase::A, CutCase::B, CutCase::C, CutCase::D, CutCase::E, CutCase::X, CutCase::Y, CutCase::Z})
    EXPECT_GT(seen[c], 0) << cutCaseName(c);
}

TEST(Decompose, ChildVolumeBoundFollowsTheSnapFraction) {
  const double b1 = minimumChildVolumeFraction(0.1, 0.1);
  const double b2 = minimumChildVolumeFraction(0.2, 0.1);
  EXPECT_GT(b1, 0.0);
  EXPECT_GT(b2, b1);  // a larger snap fraction forbids thinner children
  // Case A at its extreme corner gives the corner tet t^3 of the parent: the bound can be no larger.
  EXPECT_LE(b2, 0.2 * 0.2 * 0.2 + 1e-15);
  std::printf("child volume bound: tau 0.1 -> %.3g, tau 0.2 -> %.3g\n", b1, b2);
}

}  // namespace
}  // namespace blobvk::cutting

namespace blobvk::cutting {
namespace {

// The cutter memoizes decomposeTet by the rank pattern of the keys: for random global keys
// (ties among the unused cut-point keys, as the cutter passes them) the memo must return exactly
// the direct result, on first use and on every hit.
TEST(Decompose, CacheReturnsTheDirectDecomposition) {
  DecompositionCache cache;
  std::mt19937_64 rng(11);
  int compared = 0;
  for (int round = 0; round < 10; ++round)
    for (int nodeMask = 0; nodeMask < 16; ++nodeMask)
      for (int edgeMask = 1; edgeMask < 64; ++edgeMask) {
        if (!validMasks(edgeMask, nodeMask)) continue;
        std::array<std::uint64_t, 11> keys{};
        for (int i = 0; i < 4; ++i) keys[std::size_t(i)] = rng() % 1000;  // node keys, distinct below
        while (keys[0] == keys[1] || keys[0] == keys[2] || keys[0] == keys[3] || keys[1] == keys[2] ||
               keys[1] == keys[3] || keys[2] == keys[3])
          keys[std::size_t(rng() % 4)] = rng() % 1000;
        for (int e = 0; e < 6; ++e)
          keys[std::size_t(kEdgePointBase + e)] = (edgeMask >> e & 1) ? 1000 + rng() % 1000 : ~0ull - 1;
        keys[kSteinerLocal] = ~0ull;
        for (bool forcePartial : {false, true}) {
          const Decomposition direct = decomposeTet(std::uint8_t(edgeMask), std::uint8_t(nodeMask), keys, forcePartial);
          const Decomposition cached = cache.get(std::uint8_t(edgeMask), std::uint8_t(nodeMask), keys, forcePartial);
          ASSERT_EQ(cached.kind, direct.kind);
          ASSERT_EQ(cached.separating, direct.separating);
          ASSERT_EQ(cached.usesSteiner, direct.usesSteiner);
          ASSERT_EQ(cached.tetCount, direct.tetCount);
          ASSERT_EQ(cached.crackCount, direct.crackCount);
          for (int i = 0; i < direct.tetCount; ++i) ASSERT_EQ(cached.tets[std::size_t(i)], direct.tets[std::size_t(i)]);
          for (int i = 0; i < direct.crackCount; ++i)
            ASSERT_EQ(cached.crack[std::size_t(i)], direct.crack[std::size_t(i)]);
          // Other keys in the same order: a hit, with the same result.
          std::array<std::uint64_t, 11> shifted = keys;
          for (auto& k : shifted)
            if (k < 5000) k = 3 * k + 7;
          const std::size_t entries = cache.size();
          const Decomposition hit = cache.get(std::uint8_t(edgeMask), std::uint8_t(nodeMask), shifted, forcePartial);
          ASSERT_EQ(cache.size(), entries);
          ASSERT_EQ(hit.tetCount, direct.tetCount);
          for (int i = 0; i < direct.tetCount; ++i) ASSERT_EQ(hit.tets[std::size_t(i)], direct.tets[std::size_t(i)]);
          ++compared;
        }
      }
  EXPECT_GT(compared, 1500);
}

TEST(Decompose, CacheRejectsForbiddenMasksWithoutCachingThem) {
  DecompositionCache cache;
  std::array<std::uint64_t, 11> keys{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  // Edge e5 = (0, 1) cut while node 0 is a cut node: the filtering forbids it.
  EXPECT_THROW(cache.get(std::uint8_t(1u << 5), 0b0001, keys), std::invalid_argument);
  EXPECT_EQ(cache.size(), 0u);
}

}  // namespace
}  // namespace blobvk::cutting
