// The spatial hash's slab query must never miss a tet that meets a swept triangle: checked
// against brute force on random triangles, before and after cuts (stale entries, new tets).
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/vec.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace blobvk::cutting {
namespace {

// Does the tet come within `pad` of the triangle? Sampled: a point of the tet (barycentric grid)
// within pad + the sampling spacing of the triangle's plane, inside its prism.
bool tetNearTriangle(const CutTopology& topo, std::uint32_t slot, const Triangle& t, double pad) {
  const auto& p = topo.mesh().positions;
  const Tet& tet = topo.tet(slot);
  const Double3 n0 = cross(t[1] - t[0], t[2] - t[0]);
  const Double3 n = n0 * (1.0 / length(n0));
  const int steps = 6;
  for (int a = 0; a <= steps; ++a)
    for (int b = 0; a + b <= steps; ++b)
      for (int c = 0; a + b + c <= steps; ++c) {
        const int d = steps - a - b - c;
        const Double3 q = (p[tet[0]] * a + p[tet[1]] * b + p[tet[2]] * c + p[tet[3]] * d) * (1.0 / steps);
        if (std::fabs(dot(q - t[0], n)) > pad) continue;
        bool inside = true;
        for (int e = 0; e < 3; ++e) {
          const Double3 m = cross(t[(e + 1) % 3] - t[e], n);
          if (dot(q - t[e], m) > pad * length(m)) inside = false;
        }
        if (inside) return true;
      }
  return false;
}

// How a test keeps its grid up to date after a cut: insert every changed slot, or (as the
// cutter does) only record the smaller box of a slot whose new content lies inside its old box.
// A third way, also the cutter's: shrink the reused slots and let each split's further children
// join the family of their parent's slot.
enum class Update { InsertAll, ShrinkReusedSlots, CoverChildren };

void slabQueryFindsEveryTetNearRandomTriangles(Update update) {
  // The families below follow the splits' change set (parent slot, then its children); flips
  // write slots whose content leaves the parent's box, which the cutter registers by insert():
  // the first two ways see them, the third is the splits' protocol alone.
  CutOptions options;
  if (update == Update::CoverChildren) options.improveBelowDeg = 0;
  Cutter cutter(test::cubeMesh(8), options);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-1.0, 9.0);
  std::size_t checked = 0, found = 0;
  SpatialGrid grid;
  grid.rebuild(cutter.topology());
  for (int round = 0; round < 40; ++round) {
    const Triangle tri{Double3{coord(rng), coord(rng), coord(rng)}, Double3{coord(rng), coord(rng), coord(rng)},
                       Double3{coord(rng), coord(rng), coord(rng)}};
    if (length(cross(tri[1] - tri[0], tri[2] - tri[0])) < 1e-3) continue;
    const CutTopology& topo = cutter.topology();
    std::vector<std::uint32_t> hits;
    grid.querySlabs(topo, {SpatialGrid::slabAround(tri, 0.01)}, hits);
    ASSERT_TRUE(std::is_sorted(hits.begin(), hits.end()));
    ASSERT_TRUE(std::adjacent_find(hits.begin(), hits.end()) == hits.end());
    for (std::uint32_t s = 0; s < topo.slotCount(); ++s) {
      if (!topo.alive(s) || !tetNearTriangle(topo, s, tri, 0.01)) continue;
      ++checked;
      ASSERT_TRUE(std::binary_search(hits.begin(), hits.end(), s)) << "round " << round << " missed slot " << s;
    }
    found += hits.size();
    // Cut along the triangle every few rounds, so later queries see split and renumbered tets.
    if (round % 4 != 0) continue;
    const CutResult r = cutter.cut({tri});
    std::vector<std::uint32_t> reused(r.removedTets);
    std::sort(reused.begin(), reused.end());
    if (update != Update::InsertAll) {  // split children and renumbered tets stay in their old box
      for (std::size_t i = 0; i < r.removedTets.size(); ++i)
        grid.shrink(cutter.topology(), r.removedTets[i], r.removedTetNodes[i]);
      // A node the smoothing moved takes its tets (same nodes) out of their old boxes.
      for (const MovedNode& m : r.movedNodes)
        for (std::uint32_t slot : cutter.topology().tetsOfNode(m.index)) grid.insert(cutter.topology(), slot);
    }
    if (update == Update::CoverChildren) {
      // addedTets lists each split's parent slot (reused by its first child) before its other
      // children; removedTets lists the parents in the same order.
      std::size_t parent = 0;
      for (std::size_t i = 0; i < r.addedTets.size(); ++i) {
        const std::uint32_t slot = r.addedTets[i];
        if (std::binary_search(reused.begin(), reused.end(), slot)) {
          parent = std::size_t(std::find(r.removedTets.begin(), r.removedTets.end(), slot) - r.removedTets.begin());
          continue;
        }
        grid.cover(cutter.topology(), std::span<const std::uint32_t>(&r.addedTets[i], 1), r.removedTets[parent],
                   r.removedTetNodes[parent]);
      }
      continue;
    }
    for (std::uint32_t slot : r.addedTets)
      if (update == Update::InsertAll || !std::binary_search(reused.begin(), reused.end(), slot))
        grid.insert(cutter.topology(), slot);
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_LT(found, 40u * cutter.topology().liveTetCount());  // far from returning everything
}

TEST(SpatialGrid, SlabQueryFindsEveryTetNearRandomTriangles) {
  slabQueryFindsEveryTetNearRandomTriangles(Update::InsertAll);
}

TEST(SpatialGrid, ShrinkingReusedSlotsKeepsTheQueryComplete) {
  slabQueryFindsEveryTetNearRandomTriangles(Update::ShrinkReusedSlots);
}

TEST(SpatialGrid, CoveredChildrenKeepTheQueryComplete) {
  slabQueryFindsEveryTetNearRandomTriangles(Update::CoverChildren);
}

// A slot given back (a 3-2 flip's freed slot takes the last one's content, and the last slot goes):
// release() must take it out of its family, or a tet that later reuses the slot and joins
// another family cuts the first family's list short, and must hand its own family's members
// entries of their own, or they are found through nothing once the slot is gone. Splits into
// four around the centroid stand for the cutter's (children inside the parent's box).
TEST(SpatialGrid, ReleasedSlotLeavesItsFamilyAndHandsOverItsMembers) {
  CutTopology topo(test::cubeMesh(4));
  SpatialGrid grid;
  grid.rebuild(topo);
  auto split = [&](std::uint32_t slot) {
    const Tet t = topo.tet(slot);
    const auto& r = topo.mesh().restPositions;
    const Double3 c = (r[t[0]] + r[t[1]] + r[t[2]] + r[t[3]]) * 0.25;
    const std::uint32_t centre = topo.addNode(c, c);
    std::vector<std::uint32_t> others;
    for (int i = 0; i < 4; ++i) {
      Tet child = t;
      child[std::size_t(i)] = centre;
      if (i == 0) topo.setTet(slot, child);
      else others.push_back(topo.addTet(child, topo.mesh().regions[slot]));
    }
    grid.shrink(topo, slot, t);
    grid.cover(topo, others, slot, t);
    return others;
  };
  const std::uint32_t last = std::uint32_t(topo.slotCount() - 1);
  const std::vector<std::uint32_t> kids = split(0);  // slot 0's family lists kids[2], kids[1], kids[0]
  const std::uint32_t released = kids[1];
  const std::vector<std::uint32_t> grandkids = split(released);
  grid.release(topo, released);
  topo.removeTet(released);
  // A split far away reuses the slot (addTet takes the free slot first) for a child of another family.
  const std::vector<std::uint32_t> farKids = split(last);
  ASSERT_EQ(farKids[0], released);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-0.5, 4.5);
  std::size_t checked = 0;
  std::vector<std::uint8_t> met(topo.slotCount(), 0);
  // Every other triangle is centred on one of the slots the release concerns.
  std::vector<std::uint32_t> targets(grandkids);
  targets.push_back(kids[0]);
  for (int round = 0; round < 200; ++round) {
    Triangle tri{Double3{coord(rng), coord(rng), coord(rng)}, Double3{coord(rng), coord(rng), coord(rng)},
                 Double3{coord(rng), coord(rng), coord(rng)}};
    if (length(cross(tri[1] - tri[0], tri[2] - tri[0])) < 1e-3) continue;
    if (round % 2) {
      const Tet& t = topo.tet(targets[std::size_t(round / 2) % targets.size()]);
      const auto& p = topo.mesh().positions;
      const Double3 shift = (p[t[0]] + p[t[1]] + p[t[2]] + p[t[3]]) * 0.25 - (tri[0] + tri[1] + tri[2]) * (1.0 / 3.0);
      for (Double3& v : tri) v = v + shift;
    }
    std::vector<std::uint32_t> hits;
    grid.querySlabs(topo, {SpatialGrid::slabAround(tri, 0.01)}, hits);
    for (std::uint32_t s = 0; s < topo.slotCount(); ++s) {
      if (!topo.alive(s) || !tetNearTriangle(topo, s, tri, 0.01)) continue;
      ++checked;
      met[s] = 1;
      ASSERT_TRUE(std::binary_search(hits.begin(), hits.end(), s)) << "round " << round << " missed slot " << s;
    }
  }
  EXPECT_GT(checked, 1000u);
  // The family's member after the released slot, and the released slot's own family, were met.
  EXPECT_TRUE(met[kids[0]]);
  for (std::uint32_t s : grandkids) EXPECT_TRUE(met[s]) << "slot " << s;
}

}  // namespace
}  // namespace blobvk::cutting
