// Where slivers come from: the 100 random strokes of TetgenStrokes, with every split of every
// event traced back to its cut case (cut edges, Steiner point or not, children) and the quality
// of its parent. Prints, per case, how many children fall below 1 and 5 deg, how many of those
// come from a parent that was itself above 10 deg (slivers made at source rather than a bad tet
// cut again), and the worst. Asserts what the trace relies on: each split's children tile its
// parent (their rest volumes sum to the parent's to rounding: 1e-9 relative, the
// children of a sliver lose digits).
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/vec.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"
#include "random_strokes.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>

namespace blobvk::cutting {
namespace {

double minDihedral(const std::vector<mesh::Double3>& rest, const Tet& t) {
  return tetQuality(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]]).minDihedralDeg;
}

struct CaseTally {
  std::size_t splits = 0, children = 0, below1 = 0, below5 = 0, below5FromGood = 0;
  double worst = 180, worstFromGood = 180;
};

TEST(SliverSources, EveryChildBelowFiveDegreesIsTracedToItsCutCase) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 1.5e-3;
  CutOptions cut;
  cut.improveBelowDeg = 0;  // the splits as made, before any flip
  Cutter cutter(fem::tetrahedralize(testing::icosphere(2), options), cut);
  test::RandomStrokes strokes(16);
  std::map<std::string, CaseTally> tally;
  for (int stroke = 0; stroke < 100; ++stroke)
    for (const auto& swept : strokes.next()) {
      const std::size_t slotsBefore = cutter.topology().slotCount();
      const CutResult r = cutter.cut(swept);
      const auto& rest = cutter.topology().mesh().restPositions;
      // New nodes of this event: edge points by their edge, Steiner points, duplicates' sources.
      std::map<std::uint64_t, std::uint32_t> pointOfEdge;
      std::map<std::uint32_t, const NewNode*> created;
      for (const NewNode& n : r.newNodes) {
        created[n.index] = &n;
        if (n.kind == NewNode::Kind::EdgePoint) pointOfEdge[edgeKey(n.sources[0], n.sources[1])] = n.index;
      }
      auto origin = [&](std::uint32_t v) {
        for (auto it = created.find(v); it != created.end() && it->second->kind == NewNode::Kind::Duplicate;
             it = created.find(v))
          v = it->second->sources[0];
        return v;
      };
      // Split i: parent removedTets[i]; children: its slot, then the slots appended after it.
      std::size_t next = 0;
      for (std::size_t i = 0; i < r.splitTets; ++i) {
        const Tet& parent = r.removedTetNodes[i];
        ASSERT_EQ(r.addedTets[next], r.removedTets[i]);
        std::vector<std::uint32_t> children{r.addedTets[next++]};
        while (next < r.addedTets.size() && r.addedTets[next] >= slotsBefore) children.push_back(r.addedTets[next++]);
        int edges = 0;
        for (const auto& e : kTetEdges) edges += pointOfEdge.count(edgeKey(parent[e[0]], parent[e[1]])) > 0;
        bool steiner = false;
        double childVolume = 0;
        for (std::uint32_t c : children) {
          const Tet& t = cutter.topology().tet(c);
          childVolume += tetVolume(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]]);
          for (std::uint32_t v : t) {
            const auto it = created.find(origin(v));
            steiner = steiner || (it != created.end() && it->second->kind == NewNode::Kind::Steiner);
          }
        }
        const double parentVolume = tetVolume(rest[parent[0]], rest[parent[1]], rest[parent[2]], rest[parent[3]]);
        ASSERT_NEAR(childVolume, parentVolume, 1e-9 * parentVolume);
        const std::string key = std::to_string(edges) + " edges, " + std::to_string(children.size()) + " children" +
                                (steiner ? ", Steiner" : "");
        CaseTally& t = tally[key];
        ++t.splits;
        const double parentAngle = minDihedral(rest, parent);
        for (std::uint32_t c : children) {
          const double angle = minDihedral(rest, cutter.topology().tet(c));
          ++t.children;
          t.below1 += angle < 1;
          t.below5 += angle < 5;
          t.worst = std::min(t.worst, angle);
          if (parentAngle > 10) {
            t.below5FromGood += angle < 5;
            t.worstFromGood = std::min(t.worstFromGood, angle);
          }
        }
      }
    }
  std::printf("%-34s %7s %8s %6s %6s %14s %7s %13s\n", "case", "splits", "children", "<1deg", "<5deg",
              "<5 from >10deg", "worst", "worst from >10");
  for (const auto& [key, t] : tally)
    std::printf("%-34s %7zu %8zu %6zu %6zu %14zu %7.3f %13.3f\n", key.c_str(), t.splits, t.children, t.below1,
                t.below5, t.below5FromGood, t.worst, t.worstFromGood);
  const QualityStats after = meshQuality(cutter.topology().toTetMesh());
  std::printf("after: %s\n", after.summary().c_str());
  EXPECT_FALSE(tally.empty());
}

}  // namespace
}  // namespace blobvk::cutting
