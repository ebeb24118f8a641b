#include "blobvk/cutting/decompose.h"

#include "blobvk/cutting/topology.h"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <vector>

namespace blobvk::cutting {
namespace {

using Polygon = std::vector<std::uint8_t>;  // local ids, outward (counter-clockwise) order

int localEdge(int a, int b) {
  for (int e = 0; e < 6; ++e)
    if ((kTetEdges[e][0] == a && kTetEdges[e][1] == b) || (kTetEdges[e][0] == b && kTetEdges[e][1] == a)) return e;
  throw std::logic_error("localEdge: not an edge");
}

// Splits face f along its cut segments: the canonical, key-independent sub-polygons.
std::vector<Polygon> splitFace(int f, std::uint8_t edgeMask) {
  const auto& v = kTetFaces[f];
  std::vector<std::uint8_t> ring;
  std::vector<bool> isPoint;
  int cuts = 0;
  for (int i = 0; i < 3; ++i) {
    ring.push_back(std::uint8_t(v[i]));
    isPoint.push_back(false);
    const int e = localEdge(v[i], v[(i + 1) % 3]);
    if (edgeMask >> e & 1) {
      ring.push_back(std::uint8_t(kEdgePointBase + e));
      isPoint.push_back(true);
      ++cuts;
    }
  }
  const int n = int(ring.size());
  auto at = [&](int i) { return ring[((i % n) + n) % n]; };
  auto pointAt = [&](int i) { return bool(isPoint[((i % n) + n) % n]); };
  if (cuts == 0) return {ring};
  if (cuts == 1) {  // ring [x m y z] rotated so that m is at index 1
    int m = 0;
    while (!pointAt(m)) ++m;
    return {{at(m - 1), at(m), at(m + 2)}, {at(m), at(m + 1), at(m + 2)}};
  }
  if (cuts == 2) {  // ring [s m1 y z m2]: corner s between the two points
    int s = 0;
    while (!(!pointAt(s) && pointAt(s + 1) && pointAt(s - 1))) ++s;
    return {{at(s), at(s + 1), at(s - 1)}, {at(s + 1), at(s + 2), at(s + 3), at(s + 4)}};
  }
  // three points: three corners and the middle triangle
  return {{ring[0], ring[1], ring[5]}, {ring[1], ring[2], ring[3]}, {ring[3], ring[4], ring[5]},
          {ring[1], ring[3], ring[5]}};
}

// Fans a polygon from its smallest-key vertex.
void fan(const Polygon& p, const std::array<std::uint64_t, 11>& keys, std::vector<std::array<std::uint8_t, 3>>& out) {
  std::size_t start = 0;
  for (std::size_t i = 1; i < p.size(); ++i)
    if (keys[p[i]] < keys[p[start]]) start = i;
  for (std::size_t i = 1; i + 1 < p.size(); ++i)
    out.push_back({p[start], p[(start + i) % p.size()], p[(start + i + 1) % p.size()]});
}

void addCone(Decomposition& d, const std::array<std::uint8_t, 3>& tri, std::uint8_t apex) {
  if (d.tetCount >= kMaxSubTets) throw std::logic_error("decomposeTet: too many sub-tets");
  // Outward triangle (a, b, c) and an interior apex: (a, c, b, apex) is positively oriented.
  d.tets[d.tetCount++] = {tri[0], tri[2], tri[1], apex};
}

bool separatingSplit(std::uint8_t edgeMask, std::uint8_t nodeMask, const std::array<std::uint64_t, 11>& keys,
                     Decomposition& d) {
  // Components of the non-cut nodes joined by uncut edges.
  int comp[4] = {-1, -1, -1, -1};
  int components = 0;
  for (int i = 0; i < 4; ++i) {
    if ((nodeMask >> i & 1) || comp[i] >= 0) continue;
    std::vector<int> stack{i};
    comp[i] = components;
    while (!stack.empty()) {
      const int a = stack.back();
      stack.pop_back();
      for (int e = 0; e < 6; ++e) {
        if (edgeMask >> e & 1) continue;
        const int x = kTetEdges[e][0], y = kTetEdges[e][1];
        const int b = x == a ? y : (y == a ? x : -1);
        if (b < 0 || (nodeMask >> b & 1) || comp[b] >= 0) continue;
        comp[b] = components;
        stack.push_back(b);
      }
    }
    ++components;
  }
  if (components != 2) return false;
  for (int e = 0; e < 6; ++e) {
    const int x = kTetEdges[e][0], y = kTetEdges[e][1];
    const bool bothSolid = !(nodeMask >> x & 1) && !(nodeMask >> y & 1);
    const bool cut = edgeMask >> e & 1;
    if (cut && !bothSolid) return false;  // filtering violated
    if (bothSolid && cut != (comp[x] != comp[y])) return false;
  }
  // Side polygons: the canonical face pieces, assigned by the solid node they contain.
  std::vector<Polygon> side[2];
  for (int f = 0; f < 4; ++f)
    for (Polygon& p : splitFace(f, edgeMask)) {
      int s = -1;
      for (std::uint8_t v : p)
        if (v < 4 && !(nodeMask >> v & 1)) s = comp[v];
      if (s < 0) return false;
      side[s].push_back(std::move(p));
    }
  for (int s = 0; s < 2; ++s) {
    // The crack polygon closes the side: its edges are the side's unmatched directed edges.
    std::vector<std::pair<std::uint8_t, std::uint8_t>> open;
    for (const Polygon& p : side[s])
      for (std::size_t i = 0; i < p.size(); ++i) {
        const std::uint8_t a = p[i], b = p[(i + 1) % p.size()];
        bool matched = false;
        for (const Polygon& q : side[s])
          for (std::size_t j = 0; j < q.size(); ++j)
            if (q[j] == b && q[(j + 1) % q.size()] == a) matched = true;
        if (!matched) open.emplace_back(b, a);  // reversed: the crack's own orientation
      }
    if (open.size() < 3) return false;
    Polygon crack{open[0].first};
    std::uint8_t next = open[0].second;
    while (next != crack[0]) {
      if (crack.size() > open.size()) return false;
      crack.push_back(next);
      const auto it = std::find_if(open.begin(), open.end(), [&](const auto& e) { return e.first == next; });
      if (it == open.end()) return false;
      next = it->second;
    }
    if (crack.size() != open.size()) return false;
    std::vector<std::array<std::uint8_t, 3>> tris;
    for (const Polygon& p : side[s]) fan(p, keys, tris);
    const std::size_t faceTris = tris.size();
    fan(crack, keys, tris);
    if (s == 0)
      for (std::size_t i = faceTris; i < tris.size(); ++i) d.crack[d.crackCount++] = tris[i];
    // Cone from the side's smallest-key vertex: every polygon through it was fanned from it.
    std::uint8_t apex = tris[0][0];
    for (const auto& t : tris)
      for (std::uint8_t v : t)
        if (keys[v] < keys[apex]) apex = v;
    for (const auto& t : tris)
      if (t[0] != apex && t[1] != apex && t[2] != apex) addCone(d, t, apex);
  }
  d.separating = true;
  return true;
}

}  // namespace

std::string_view cutCaseName(CutCase c) {
  switch (c) {
    case CutCase::Untouched: return "untouched";
    case CutCase::A: return "A";
    case CutCase::B: return "B";
    case CutCase::C: return "C";
    case CutCase::D: return "D";
    case CutCase::E: return "E";
    case CutCase::X: return "X";
    case CutCase::Y: return "Y";
    case CutCase::Z: return "Z";
    case CutCase::NodesOnly: return "nodes-only";
    case CutCase::Partial: return "partial";
  }
  return "?";
}

std::uint8_t caseAEdgeCode(int node) {
  std::uint8_t code = 0;
  for (int e = 0; e < 6; ++e)
    if (kTetEdges[e][0] == node || kTetEdges[e][1] == node) code |= std::uint8_t(1u << e);
  return code;
}

namespace {

// rank[i] = number of keys below keys[i]: equal keys share a rank, so every comparison
// decomposeTet can make between two keys is answered the same way by their ranks. Packed 4 bits
// per key. The cutter's keys have a known shape: 4 distinct node keys, below every cut-point key
// (new nodes), and the Steiner key above all; then only the 4 node keys and the 6 point keys
// need ranking among themselves (21 comparisons instead of 121). Any other shape takes the
// general count; both give the same pattern.
std::uint64_t rankPattern(const std::array<std::uint64_t, 11>& keys) {
  const std::uint64_t maxNode = std::max({keys[0], keys[1], keys[2], keys[3]});
  std::uint64_t minPoint = ~0ull, maxPoint = 0;
  for (int e = kEdgePointBase; e < kSteinerLocal; ++e)
    minPoint = std::min(minPoint, keys[std::size_t(e)]), maxPoint = std::max(maxPoint, keys[std::size_t(e)]);
  const bool distinctNodes = keys[0] != keys[1] && keys[0] != keys[2] && keys[0] != keys[3] && keys[1] != keys[2] &&
                             keys[1] != keys[3] && keys[2] != keys[3];
  std::uint64_t pattern = 0;
  if (distinctNodes && maxNode < minPoint && maxPoint < keys[kSteinerLocal]) {
    for (int i = 0; i < 4; ++i) {
      const std::uint64_t rank = std::uint64_t(keys[0] < keys[std::size_t(i)]) + (keys[1] < keys[std::size_t(i)]) +
                                 (keys[2] < keys[std::size_t(i)]) + (keys[3] < keys[std::size_t(i)]);
      pattern |= rank << (4 * i);
    }
    for (int i = kEdgePointBase; i < kSteinerLocal; ++i) {
      std::uint64_t rank = 4;
      for (int j = kEdgePointBase; j < kSteinerLocal; ++j) rank += keys[std::size_t(j)] < keys[std::size_t(i)];
      pattern |= rank << (4 * i);
    }
    return pattern | std::uint64_t(10) << (4 * kSteinerLocal);
  }
  for (int i = 0; i < 11; ++i) {
    std::uint64_t rank = 0;
    for (int j = 0; j < 11; ++j) rank += keys[std::size_t(j)] < keys[std::size_t(i)];
    pattern |= rank << (4 * i);
  }
  return pattern;
}

}  // namespace

const Decomposition& DecompositionCache::get(std::uint8_t edgeMask, std::uint8_t nodeMask,
                                            const std::array<std::uint64_t, 11>& keys, bool forcePartial) {
  std::uint64_t pattern = rankPattern(keys);
  pattern |= std::uint64_t(edgeMask & 63u) << 44 | std::uint64_t(nodeMask & 15u) << 50 |
             std::uint64_t(forcePartial) << 54;
  if (const std::uint32_t* found = index_.find(pattern)) return entries_[*found];
  // Decompose the rank pattern itself (throws, uncached, on masks the filtering forbids).
  std::array<std::uint64_t, 11> ranks{};
  for (int i = 0; i < 11; ++i) ranks[std::size_t(i)] = pattern >> (4 * i) & 15u;
  entries_.push_back(decomposeTet(edgeMask, nodeMask, ranks, forcePartial));
  index_.insert(pattern, std::uint32_t(entries_.size() - 1));
  return entries_.back();
}

CutCase classifyCut(std::uint8_t edgeMask, std::uint8_t nodeMask) {
  std::array<std::uint64_t, 11> keys{};
  for (int i = 0; i < 11; ++i) keys[i] = std::uint64_t(i);
  return decomposeTet(edgeMask, nodeMask, keys).kind;
}

Decomposition decomposeTet(std::uint8_t edgeMask, std::uint8_t nodeMask, const std::array<std::uint64_t, 11>& keys,
                           bool forcePartial) {
  Decomposition d;
  const int cutEdges = std::popcount(unsigned(edgeMask));
  const int cutNodes = std::popcount(unsigned(nodeMask));
  for (int e = 0; e < 6; ++e)
    if ((edgeMask >> e & 1) && ((nodeMask >> kTetEdges[e][0] & 1) || (nodeMask >> kTetEdges[e][1] & 1)))
      throw std::invalid_argument("decomposeTet: a cut edge touches a cut node (filtering not applied)");
  if (cutEdges == 0) {
    d.kind = cutNodes == 0 ? CutCase::Untouched : (cutNodes >= 3 ? CutCase::Z : CutCase::NodesOnly);
    d.tetCount = 1;
    d.tets[0] = {0, 1, 2, 3};
    return d;
  }
  if (!forcePartial && separatingSplit(edgeMask, nodeMask, keys, d)) {
    if (cutNodes == 0) d.kind = cutEdges == 3 ? CutCase::A : CutCase::B;
    else d.kind = cutNodes == 1 ? CutCase::X : CutCase::Y;
    return d;
  }
  d = Decomposition{};
  if (cutNodes == 0 && cutEdges <= 3) d.kind = cutEdges == 1 ? CutCase::C : (cutEdges == 2 ? CutCase::D : CutCase::E);
  else d.kind = CutCase::Partial;
  // Not separating. When a node touches no cut edge (one cut edge, two on one face, three around
  // one face, any with a cut node), the tet is the cone from that node over its opposite face,
  // and the canonical split of that face gives the split of the tet: the three faces through
  // the node are cut only on their edges opposite it, i.e. through the node, as splitFace does.
  // No Steiner point: a Steiner cone's children were the thinnest a stroke left (a child 1.5 deg
  // from a 5.8 deg parent on the TetGen peanut). The node with the smallest key, so that the
  // result depends on the key order only (DecompositionCache).
  int apex = -1;
  for (int i = 0; i < 4; ++i) {
    bool touches = false;
    for (int e = 0; e < 6; ++e) touches = touches || ((edgeMask >> e & 1) && (kTetEdges[e][0] == i || kTetEdges[e][1] == i));
    if (!touches && (apex < 0 || keys[std::size_t(i)] < keys[std::size_t(apex)])) apex = i;
  }
  std::vector<std::array<std::uint8_t, 3>> tris;
  if (apex >= 0 && !forcePartial) {
    for (const Polygon& p : splitFace(apex, edgeMask)) fan(p, keys, tris);  // face i is opposite node i
    for (const auto& t : tris) addCone(d, t, std::uint8_t(apex));
    return d;
  }
  // Otherwise split every face canonically and cone it to a Steiner point. The crack stops on
  // this tet's faces; the next sweep over it continues the cut.
  for (int f = 0; f < 4; ++f)
    for (const Polygon& p : splitFace(f, edgeMask)) fan(p, keys, tris);
  for (const auto& t : tris) addCone(d, t, kSteinerLocal);
  d.usesSteiner = true;
  return d;
}

}  // namespace blobvk::cutting
