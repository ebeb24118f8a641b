#include "blobvk/cutting/local_flips.h"

#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace blobvk::cutting {
namespace {

// Triangulations of a convex n-gon (vertices 0..n-1 in cycle order), n = 4..7, each as its n - 2
// triangles (i < j < k): 2, 5, 14 and 42 of them. Built once.
using Triangulation = std::vector<std::array<std::uint8_t, 3>>;
void triangulate(int i, int j, Triangulation& current, std::vector<std::pair<int, int>> pending,
                 std::vector<Triangulation>& out) {
  // Polygon i..j (vertices i, i+1, ..., j) with base edge (i, j): a triangle (i, k, j), then the
  // two sub-polygons, handled through a list of pending ones so every combination is produced.
  if (j - i >= 2) {
    for (int k = i + 1; k < j; ++k) {
      Triangulation next = current;
      next.push_back({std::uint8_t(i), std::uint8_t(k), std::uint8_t(j)});
      auto more = pending;
      more.emplace_back(i, k);
      more.emplace_back(k, j);
      const auto [a, b] = more.back();
      more.pop_back();
      triangulate(a, b, next, more, out);
    }
    return;
  }
  if (pending.empty()) {
    out.push_back(current);
    return;
  }
  const auto [a, b] = pending.back();
  pending.pop_back();
  triangulate(a, b, current, pending, out);
}

const std::vector<Triangulation>& triangulations(int n) {
  static const std::array<std::vector<Triangulation>, 8> all = [] {
    std::array<std::vector<Triangulation>, 8> t{};
    t[3] = {Triangulation{{0, 1, 2}}};
    for (int m = 4; m <= 7; ++m) {
      Triangulation current;
      triangulate(0, m - 1, current, {}, t[std::size_t(m)]);
    }
    return t;
  }();
  return all[std::size_t(n)];
}

// Positive at rest and in the current positions, with some margin for rounding.
bool positive(const mesh::TetMesh& m, const Tet& t) {
  const auto& r = m.restPositions;
  const auto& p = m.positions;
  auto ok = [&](const std::vector<mesh::Double3>& x) {
    const double v = tetVolume(x[t[0]], x[t[1]], x[t[2]], x[t[3]]);
    // The longest of the three edges from t[0]: one square root of the largest square (sqrt is
    // monotonic and correctly rounded, so this is the largest of the three lengths, to the bit).
    const Double3 e1 = x[t[1]] - x[t[0]], e2 = x[t[2]] - x[t[0]], e3 = x[t[3]] - x[t[0]];
    const double l = std::sqrt(std::max({dot(e1, e1), dot(e2, e2), dot(e3, e3)}));
    return v > 1e-12 * l * l * l;
  };
  return ok(r) && (&r == &p || ok(p));
}

// -cos of the smallest dihedral angle: increases with that angle, and needs no acos (the acos
// was a quarter of the flips' time).
double cosineQuality(Double3 a, Double3 b, Double3 c, Double3 d) {
  // Outward normals of the faces opposite each vertex; the dihedral angle at the edge shared by
  // faces i and j is pi minus the angle between their normals: its cosine is -cos(normals).
  const std::array<Double3, 4> n{cross(c - b, d - b), cross(d - a, c - a), cross(b - a, d - a), cross(c - a, b - a)};
  std::array<double, 4> len{};
  for (int i = 0; i < 4; ++i) len[std::size_t(i)] = length(n[std::size_t(i)]);
  double worst = -1.0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double l = len[std::size_t(i)] * len[std::size_t(j)];
      if (!(l > 0)) return -1.0;
      worst = std::max(worst, -dot(n[std::size_t(i)], n[std::size_t(j)]) / l);
    }
  return -std::min(worst, 1.0);
}

// Whether the tet's smallest dihedral angle is clearly no smaller than the angle whose cosine is
// `cosine` (> 0), without square roots or divisions: every pair of outward face normals must
// satisfy -dot <= cosine |n_i| |n_j|, tested squared with a relative margin of 1e-9, far above
// the rounding of cosineQuality. Within the margin (or degenerate) it answers false and the
// caller computes cosineQuality: the decision is exactly cosineQuality's. Most tets a cut event
// writes are screened by this alone.
bool clearlyAtLeast(Double3 a, Double3 b, Double3 c, Double3 d, double cosine) {
  const std::array<Double3, 4> n{cross(c - b, d - b), cross(d - a, c - a), cross(b - a, d - a), cross(c - a, b - a)};
  std::array<double, 4> square{};
  for (int i = 0; i < 4; ++i) square[std::size_t(i)] = dot(n[std::size_t(i)], n[std::size_t(i)]);
  const double bound = cosine * cosine * (1.0 - 1e-9);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double l2 = square[std::size_t(i)] * square[std::size_t(j)];
      const double minusDot = -dot(n[std::size_t(i)], n[std::size_t(j)]);
      if (!(l2 > 0) || (minusDot > 0 && minusDot * minusDot > bound * l2)) return false;
    }
  return true;
}

// Below every quality (-cos lies in [-1, 1]).
constexpr double kInvalid = -2.0;

double quality(const mesh::TetMesh& m, const Tet& t) {
  const auto& r = m.restPositions;
  return cosineQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]);
}

// Whether the boundary edge (a, b) lies inside one flat piece of the boundary: its two boundary
// faces (a, b, first) and (a, b, last), whose tets have `afterFirst` and `beforeLast` as their
// other nodes, have outward unit normals that agree to kFlatSine (node_smoothing.cpp's bound for
// points computed on one plane). Then re-triangulating the ring moves no boundary point: the two
// faces become (a, first, last) and (b, last, first), the same piece of the plane.
constexpr double kFlatSine = 1e-10;
bool flatBoundaryEdge(const std::vector<Double3>& r, std::uint32_t a, std::uint32_t b, std::uint32_t first,
                      std::uint32_t afterFirst, std::uint32_t beforeLast, std::uint32_t last) {
  Double3 n0 = cross(r[b] - r[a], r[first] - r[a]), n1 = cross(r[b] - r[a], r[last] - r[a]);
  if (dot(n0, r[afterFirst] - r[a]) > 0) n0 = n0 * -1.0;
  if (dot(n1, r[beforeLast] - r[a]) > 0) n1 = n1 * -1.0;
  const double l0 = length(n0), l1 = length(n1);
  if (!(l0 > 0 && l1 > 0)) return false;
  return dot(n0, n1) > 0 && length(cross(n0, n1)) <= kFlatSine * l0 * l1;
}

}  // namespace

double dihedralQuality(Double3 a, Double3 b, Double3 c, Double3 d) { return cosineQuality(a, b, c, d); }

double minDihedralDeg(Double3 a, Double3 b, Double3 c, Double3 d) {
  return std::acos(std::clamp(-cosineQuality(a, b, c, d), -1.0, 1.0)) * (180.0 / 3.14159265358979323846);
}

void LocalFlips::write(CutTopology& topology, std::uint32_t slot, const Tet& nodes) {
  if (listed_.size() <= slot) listed_.resize(std::size_t(slot) + slot / 2 + 1, 0);
  if (!listed_[slot]) {
    change_->removedTets.push_back(slot);
    change_->removedTetNodes.push_back(topology.tet(slot));
    listed_[slot] = 1;
  }
  change_->addedTets.push_back(slot);
  topology.setTet(slot, nodes);
  written_.push_back(slot);
}

std::uint32_t LocalFlips::append(CutTopology& topology, const Tet& nodes, std::uint32_t region) {
  const std::uint32_t slot = topology.addTet(nodes, region);
  if (listed_.size() <= slot) listed_.resize(std::size_t(slot) + slot / 2 + 1, 0);
  listed_[slot] = 1;
  change_->addedTets.push_back(slot);
  written_.push_back(slot);
  return slot;
}

bool LocalFlips::freeable() const {
  const std::size_t slots = topology_->slotCount();
  return slots > eventFirstSlot_ && topology_->liveTetCount() == slots;
}

void LocalFlips::freeSlot(CutTopology& topology, const std::vector<std::uint32_t>& ring, const std::vector<Tet>& made) {
  // The two new tets go into two ring slots; the last slot (appended in this event: the FEM has
  // not seen it, and it is listed only as added) moves into the third ring slot, content and
  // region, unless it is one of the ring, and is given back.
  const std::uint32_t last = std::uint32_t(topology.slotCount() - 1);
  std::array<std::uint32_t, 3> keep{};
  std::size_t kept = 0;
  const bool lastInRing = std::find(ring.begin(), ring.end(), last) != ring.end();
  for (std::uint32_t s : ring)
    if (s != last && kept < 2) keep[kept++] = s;
  const std::uint32_t spare = lastInRing ? last : ring[2];
  write(topology, keep[0], made[0]);
  write(topology, keep[1], made[1]);
  if (!lastInRing) {
    // Listed as written (with its content before the event) before it takes the last slot's.
    if (!listed_[spare]) {
      change_->removedTets.push_back(spare);
      change_->removedTetNodes.push_back(topology.tet(spare));
      listed_[spare] = 1;
    }
    change_->addedTets.push_back(spare);
    written_.push_back(spare);
  }
  auto& added = change_->addedTets;
  added.erase(std::remove(added.begin(), added.end(), last), added.end());
  written_.erase(std::remove(written_.begin(), written_.end(), last), written_.end());
  listed_[last] = 0;
  grid_->release(topology, last);
  topology.removeTet(spare);
  topology.compact();  // the only hole is `spare`: the last slot moves into it (or is cut off)
}

bool LocalFlips::improveTet(CutTopology& topology, std::uint32_t slot, double belowCosine, FlipStats& stats) {
  const mesh::TetMesh& m = topology.mesh();
  const Tet t = topology.tet(slot);
  const auto& rest = m.restPositions;
  if (belowCosine > 0 && clearlyAtLeast(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]], belowCosine)) return false;
  const double own = quality(m, t);
  if (own >= -belowCosine) return false;
  const std::uint32_t region = m.regions.empty() ? 0u : m.regions[slot];
  auto regionOf = [&](std::uint32_t s) { return m.regions.empty() ? 0u : m.regions[s]; };
  ++stats.attempts;
  double bestQuality = own;  // an operation must raise the minimum of what it replaces
  enum class Op { None, Face, Edge } bestOp = Op::None;
  std::uint32_t bestOther = kNone;
  bool bestOpen = false;  // the edge removal's ring is open (a boundary edge)
  std::vector<std::uint32_t> bestRing;
  best_.clear();

  // Face removal: the tet and its neighbour across face i become three tets around (t[i], e).
  for (int i = 0; i < 4; ++i) {
    const auto& f = kTetFaces[std::size_t(i)];
    const auto pair = topology.tetsOfFace(t[std::size_t(f[0])], t[std::size_t(f[1])], t[std::size_t(f[2])]);
    const std::uint32_t other = pair[0] == slot ? pair[1] : pair[0];
    if (other == kNone || regionOf(other) != region) continue;
    const Tet& u = topology.tet(other);
    std::uint32_t e = kNone;
    for (std::uint32_t v : u)
      if (v != t[0] && v != t[1] && v != t[2] && v != t[3]) e = v;
    if (e == kNone) continue;
    // Each new tet is the tet with one of the face's nodes replaced by e: positive exactly when
    // e lies beyond the face on that side (the union is convex there).
    std::array<Tet, 3> made{};
    double worst = 1e300;
    bool valid = !topology.hasEdge(t[std::size_t(i)], e);
    // bestQuality starts at the tet's own quality, which is at least the neighbour pair's minimum.
    const double bar = bestQuality + 1e-9;
    for (int k = 0; k < 3 && valid; ++k) {
      made[std::size_t(k)] = t;
      made[std::size_t(k)][std::size_t(f[std::size_t(k)])] = e;
      worst = std::min(worst, quality(m, made[std::size_t(k)]));
      // No better than the bar: the rest need not be evaluated (the sign only for a candidate).
      valid = worst > bar && positive(m, made[std::size_t(k)]);
    }
    if (valid) {
      bestQuality = worst;
      bestOp = Op::Face;
      bestOther = other;
      best_.assign(made.begin(), made.end());
    }
  }

  // Edge removal: the ring of tets around edge (a, b) (closed, 3..7 tets; or open, 2..6 tets, in a
  // flat piece of the boundary) becomes the cones from a and b over a triangulation of the ring
  // polygon (an open ring's closed by the new boundary edge). Every edge of the tet is tried: restricting
  // the tries to the edges where its dihedral angle is bad halved the gain on the random strokes.
  const auto& r = m.restPositions;
  for (const auto& e : kTetEdges) {
    const std::uint32_t a = t[std::size_t(e[0])], b = t[std::size_t(e[1])];
    ring_.clear();
    for (std::uint32_t s : topology.tetsOfNode(a)) {
      const Tet& u = topology.tet(s);
      if (std::find(u.begin(), u.end(), b) != u.end()) ring_.push_back(s);
    }
    const int n = int(ring_.size());
    // Closed rings of 3..7 tets (3 only when a slot can be given back, see freeable); open rings
    // (a boundary edge) of 2..6 tets, whose polygon then has n + 1 vertices.
    if (n < 2 || n > 7) continue;
    bool sameRegion = true;
    // Cycle: for the tet with other nodes {p, q}, (a, b, p, q) positive means q follows p.
    std::array<std::uint32_t, 7> from{}, to{};
    for (int k = 0; k < n; ++k) {
      const Tet& u = topology.tet(ring_[std::size_t(k)]);
      sameRegion = sameRegion && regionOf(ring_[std::size_t(k)]) == region;
      std::uint32_t p = kNone, q = kNone;
      for (std::uint32_t v : u)
        if (v != a && v != b) (p == kNone ? p : q) = v;
      if (tetVolume(r[a], r[b], r[p], r[q]) < 0) std::swap(p, q);
      from[std::size_t(k)] = p, to[std::size_t(k)] = q;
    }
    if (!sameRegion) continue;
    // An open ring starts at the one `from` that no tet's `to` reaches (the edge is then on the
    // boundary, between the boundary faces (a, b, first) and (a, b, last)); a closed ring anywhere.
    std::uint32_t start = from[0];
    int starts = 0;
    for (int k = 0; k < n; ++k) {
      bool reached = false;
      for (int j = 0; j < n; ++j) reached = reached || to[std::size_t(j)] == from[std::size_t(k)];
      if (!reached) start = from[std::size_t(k)], ++starts;
    }
    const bool open = starts > 0;
    if (starts > 1 || (!open && (n == 2 || (n == 3 && !freeable()))) || (open && n == 7)) continue;
    const int corners = open ? n + 1 : n;  // vertices of the ring's polygon
    std::array<std::uint32_t, 8> cycle{};
    cycle[0] = start;
    bool chained = true;
    for (int k = 1; k <= n && chained; ++k) {
      const std::uint32_t prev = cycle[std::size_t(k - 1)];
      int next = -1;
      for (int j = 0; j < n; ++j)
        if (from[std::size_t(j)] == prev) next = j;
      if (next < 0) chained = false;
      else if (k < corners) cycle[std::size_t(k)] = to[std::size_t(next)];
      else chained = to[std::size_t(next)] == cycle[0];
    }
    if (!chained) continue;
    for (int x = 0; x < corners && chained; ++x)
      for (int y = x + 1; y < corners; ++y)
        if (cycle[std::size_t(x)] == cycle[std::size_t(y)]) chained = false;
    if (!chained || (open && !flatBoundaryEdge(r, a, b, cycle[0], cycle[1], cycle[std::size_t(n - 1)], cycle[std::size_t(n)])))
      continue;
    // Quality of the two cones over a triangle of the polygon, evaluated when a triangulation
    // first needs it and kept (kInvalid: invalid, or no better than the bar every triangulation
    // must clear). Most triangulations fail on their first bad triangle, so most of the
    // C(n, 3) cone pairs are never evaluated (evaluating them all was most of the flips' time).
    // The ring's smallest quality is at most the tet's own, where bestQuality starts: an operation
    // that beats bestQuality raises the minimum of what it replaces.
    const double bar = bestQuality + 1e-9;
    constexpr double kUnknown = 4.0;
    std::array<std::array<std::array<double, 7>, 7>, 7> cone;  // only i < j < k < corners are reset and read
    for (int i = 0; i < corners; ++i)
      for (int j = i + 1; j < corners; ++j)
        for (int k = j + 1; k < corners; ++k) cone[std::size_t(i)][std::size_t(j)][std::size_t(k)] = kUnknown;
    auto coneQuality = [&](int i, int j, int k) {
      double& q = cone[std::size_t(i)][std::size_t(j)][std::size_t(k)];
      if (q != kUnknown) return q;
      const std::uint32_t ri = cycle[std::size_t(i)], rj = cycle[std::size_t(j)], rk = cycle[std::size_t(k)];
      const Tet below{ri, rj, rk, b}, above{rk, rj, ri, a};
      // The quality first (it fails more often than the sign), the signs only for a candidate.
      double value = quality(m, below);
      if (value > bar) value = std::min(value, quality(m, above));
      if (value > bar && !(positive(m, below) && positive(m, above))) value = kInvalid;
      return q = value > bar ? value : kInvalid;
    };
    // A diagonal that is already an edge elsewhere rules its triangulation out; checked only for
    // a triangulation that would be taken (a few incidence scans instead of one per triangle).
    // An open ring's polygon has no side from its last corner back to its first: that edge is new.
    auto diagonalsFree = [&](const Triangulation& tri) {
      for (const auto& [i, j, k] : tri)
        if ((j - i > 1 && topology.hasEdge(cycle[i], cycle[j])) || (k - j > 1 && topology.hasEdge(cycle[j], cycle[k])) ||
            ((open || !(i == 0 && k == corners - 1)) && topology.hasEdge(cycle[i], cycle[k])))
          return false;
      return true;
    };
    const Triangulation* chosen = nullptr;
    double chosenQuality = bar;
    // With three tets the two new ones share the face of the ring's nodes: it must not exist.
    if (!open && n == 3 && topology.tetsOfFace(cycle[0], cycle[1], cycle[2])[0] != kNone) continue;
    for (const Triangulation& tri : triangulations(corners)) {
      double worst = 1e300;
      for (const auto& [i, j, k] : tri) {
        worst = std::min(worst, coneQuality(i, j, k));
        if (worst <= chosenQuality) break;
      }
      if (worst > chosenQuality && diagonalsFree(tri)) chosenQuality = worst, chosen = &tri;
    }
    if (chosen == nullptr) continue;
    bestQuality = chosenQuality;
    bestOp = Op::Edge;
    bestOpen = open;
    bestRing.assign(ring_.begin(), ring_.end());
    best_.clear();
    for (const auto& [i, j, k] : *chosen) {
      best_.push_back({cycle[i], cycle[j], cycle[k], b});
      best_.push_back({cycle[k], cycle[j], cycle[i], a});
    }
  }

  if (bestOp == Op::None) return false;
  if (bestOp == Op::Face) {
    ++stats.faceRemovals;
    write(topology, slot, best_[0]);
    write(topology, bestOther, best_[1]);
    append(topology, best_[2], region);
  } else {
    ++stats.edgeRemovals;
    stats.boundaryEdgeRemovals += bestOpen;
    std::sort(bestRing.begin(), bestRing.end());
    if (bestRing.size() == 3 && !bestOpen) {
      ++stats.threeTwo;
      freeSlot(topology, bestRing, best_);
      return true;
    }
    for (std::size_t k = 0; k < best_.size(); ++k)
      if (k < bestRing.size()) write(topology, bestRing[k], best_[k]);
      else append(topology, best_[k], region);
  }
  return true;
}

FlipStats LocalFlips::improve(CutTopology& topology, SpatialGrid& grid, std::span<const std::uint32_t> seeds,
                              double belowDeg, std::size_t maxAttempts, std::size_t eventFirstSlot,
                              FlipChangeSet change) {
  FlipStats stats;
  change_ = &change;
  grid_ = &grid;
  eventFirstSlot_ = eventFirstSlot;
  if (listed_.size() < topology.slotCount()) listed_.resize(topology.slotCount() + topology.slotCount() / 2, 0);
  for (std::uint32_t s : change.addedTets) listed_[s] = 1;
  topology_ = &topology;
  queue_.assign(seeds.begin(), seeds.end());
  const double belowCosine = std::cos(belowDeg * (3.14159265358979323846 / 180.0));
  for (std::size_t q = 0; q < queue_.size() && stats.attempts < maxAttempts; ++q) {
    const std::uint32_t slot = queue_[q];
    if (slot >= topology.slotCount() || !topology.alive(slot)) continue;
    written_.clear();
    if (!improveTet(topology, slot, belowCosine, stats)) continue;
    for (std::uint32_t s : written_) {
      grid.insert(topology, s);
      queue_.push_back(s);  // still bad: tried again (an operation around it may now exist)
    }
  }
  for (std::uint32_t s : change.addedTets) listed_[s] = 0;
  change_ = nullptr;
  topology_ = nullptr;
  grid_ = nullptr;
  return stats;
}

}  // namespace blobvk::cutting
