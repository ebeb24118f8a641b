// Topology changes like the ones cutting/ makes, built on a copy of the mesh: splitting every
// tet around an edge at an interior point, and duplicating nodes across a crack.
#pragma once

#include "blobvk/fem/simulation.h"

#include <algorithm>
#include <functional>
#include <utility>

namespace blobvk::fem::test {

// Accumulates edits on a copy of the tets and turns them into one TopologyChange.
class ChangeBuilder {
 public:
  explicit ChangeBuilder(const mesh::TetMesh& m)
      : tets_(m.tets), regions_(m.regions), touched_(m.tets.size(), 0), oldTets_(m.tets.size()), nodes_(m.nodeCount()) {
    if (regions_.empty()) regions_.assign(tets_.size(), 0);
  }

  // New node at (1 - w) a + w b; every tet holding edge (a, b) becomes two.
  std::uint32_t splitEdge(std::uint32_t a, std::uint32_t b, double w = 0.5) {
    NodeOrigin o;
    o.sources = {a, b, kNoSource, kNoSource};
    o.weights = {1 - w, w, 0, 0};
    change_.newNodes.push_back(o);
    const std::uint32_t m = std::uint32_t(nodes_++);
    const std::size_t count = tets_.size();
    for (std::size_t t = 0; t < count; ++t) {
      auto& tet = tets_[t];
      const auto ia = std::find(tet.begin(), tet.end(), a), ib = std::find(tet.begin(), tet.end(), b);
      if (ia == tet.end() || ib == tet.end()) continue;
      auto other = tet;
      other[std::size_t(ia - tet.begin())] = m;  // keeps the orientation: m lies on edge ab
      tet[std::size_t(ib - tet.begin())] = m;
      touch(t);
      tets_.push_back(other);
      regions_.push_back(regions_[t]);
    }
    return m;
  }

  // Duplicates `node`; the tets for which `moves(tet)` is true take the copy.
  std::uint32_t crack(std::uint32_t node, const std::function<bool(std::size_t tet)>& moves) {
    NodeOrigin o;
    o.sources = {node, kNoSource, kNoSource, kNoSource};
    o.weights = {1, 0, 0, 0};
    change_.newNodes.push_back(o);
    const std::uint32_t copy = std::uint32_t(nodes_++);
    for (std::size_t t = 0; t < tets_.size(); ++t) {
      auto& tet = tets_[t];
      const auto it = std::find(tet.begin(), tet.end(), node);
      if (it == tet.end() || !moves(t)) continue;
      *it = copy;
      touch(t);
    }
    return copy;
  }

  const std::array<std::uint32_t, 4>& tet(std::size_t t) const { return tets_[t]; }
  std::size_t tetCount() const { return tets_.size(); }

  TopologyChange build() const {
    TopologyChange c = change_;
    for (std::size_t t = 0; t < tets_.size(); ++t) {
      if (t < oldTets_ && !touched_[t]) continue;
      c.tetSlots.push_back(std::uint32_t(t));
      c.tetNodes.push_back(tets_[t]);
      c.tetRegions.push_back(regions_[t]);
    }
    return c;
  }

 private:
  void touch(std::size_t t) {
    if (t < oldTets_) touched_[t] = 1;  // appended tets are always part of the change
  }

  std::vector<std::array<std::uint32_t, 4>> tets_;
  std::vector<std::uint32_t> regions_;
  std::vector<unsigned char> touched_;
  std::size_t oldTets_, nodes_;
  TopologyChange change_;
};

}  // namespace blobvk::fem::test
