#include "blobvk/cutting/node_smoothing.h"

#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <cmath>

namespace blobvk::cutting {
namespace {

// Boundary faces around a node are one plane when their unit normals agree to this sine: the
// rounding of points computed on one swept triangle (~1e-15 relative), with room; a move within
// such a fan changes the volume by at most ~this x edge^3.
constexpr double kFlatSine = 1e-10;
// A node on a crease (its boundary faces in two planes) slides along the planes' line only when
// they meet at more than ~6 deg: the line's direction then carries the planes' rounding into at
// most ~10 x kFlatSine off either plane.
constexpr double kCreaseSine = 0.1;

// Positive with the same margin for rounding as the flips ask of a new tet.
bool positiveAt(const std::vector<Double3>& x, const Tet& t, std::uint32_t node, Double3 at) {
  auto p = [&](std::uint32_t v) { return v == node ? at : x[v]; };
  const Double3 a = p(t[0]), b = p(t[1]), c = p(t[2]), d = p(t[3]);
  const double l = std::max({length(b - a), length(c - a), length(d - a)});
  return tetVolume(a, b, c, d) > 1e-12 * l * l * l;
}

double qualityAt(const std::vector<Double3>& x, const Tet& t, std::uint32_t node, Double3 at) {
  auto p = [&](std::uint32_t v) { return v == node ? at : x[v]; };
  return dihedralQuality(p(t[0]), p(t[1]), p(t[2]), p(t[3]));
}

}  // namespace

bool NodeSmoothing::tryNode(CutTopology& topology, std::uint32_t node, double threshold, const std::vector<double>& onCut,
                            const std::vector<Double3>& snapPlane, MovedNode& move) {
  const mesh::TetMesh& m = topology.mesh();
  const auto incident = topology.tetsOfNode(node);
  if (incident.empty()) return false;
  star_.assign(incident.begin(), incident.end());
  const std::uint32_t region = m.regions.empty() ? 0u : m.regions[star_[0]];
  for (std::uint32_t s : star_)
    if (!m.regions.empty() && m.regions[s] != region) return false;
  const auto& rest = m.restPositions;
  const auto& pos = m.positions;
  const Double3 from = rest[node];
  // The link (the faces opposite the node). In a conforming mesh each of its edges is used by one
  // or two tets of the star: two for an interior face through the node, one for a boundary face
  // (crack faces included) through it.
  linkEdges_.clear();
  for (std::uint32_t s : star_) {
    const Tet& t = topology.tet(s);
    std::array<std::uint32_t, 3> o{};
    std::size_t k = 0;
    for (std::uint32_t v : t)
      if (v != node) o[k++] = v;
    linkEdges_.push_back(edgeKey(o[0], o[1]));
    linkEdges_.push_back(edgeKey(o[0], o[2]));
    linkEdges_.push_back(edgeKey(o[1], o[2]));
  }
  std::sort(linkEdges_.begin(), linkEdges_.end());
  std::size_t distinctEdges = 0;
  boundaryEdges_.clear();
  for (std::size_t i = 0; i < linkEdges_.size();) {
    std::size_t j = i + 1;
    while (j < linkEdges_.size() && linkEdges_[j] == linkEdges_[i]) ++j;
    if (j - i > 2) return false;
    if (j - i == 1) boundaryEdges_.push_back(linkEdges_[i]);
    ++distinctEdges;
    i = j;
  }
  linkNodes_.clear();
  for (std::uint32_t s : star_)
    for (std::uint32_t v : topology.tet(s))
      if (v != node) linkNodes_.push_back(v);
  std::sort(linkNodes_.begin(), linkNodes_.end());
  const std::size_t vertices = std::size_t(std::unique(linkNodes_.begin(), linkNodes_.end()) - linkNodes_.begin());
  // Interior: the link is one sphere (V - E + F = 2), not several touching at the node; only then
  // is the union of the star a ball around the node that a move keeps. A node on a cut surface
  // whose crack is not open stays: moving it would move the crack.
  // On the boundary: the link is one disk (V - E + F = 1, its rim one cycle: every rim node on two
  // rim edges) and the boundary faces around the node lie in one plane (a flat piece of the
  // surface or of a crack sheet). The node may then slide within that plane: the boundary faces
  // still tile the same polygon (the star's tets stay positive, so none folds over), so the shape,
  // the crack and the volume are kept.
  Double3 normal{0, 0, 0};  // of the plane a boundary node slides in
  bool crease = false;       // two planes: the node slides along their line, `line`
  Double3 line{0, 0, 0};
  bool planar = !boundaryEdges_.empty();  // candidates are projected into `normal`'s plane
  // A spike: the node is in one tet, all three faces through it on the boundary, and all four
  // nodes of that tet on cut surfaces (a piece between crack sheets that the cuts left hanging
  // off the body; a face with a node of the body's own surface, as where a case-A split's small
  // tet meets it, is never moved). It may slide parallel to its opposite face: the tet's height
  // over that face, so its volume, is kept; the spike's own three boundary faces move (the only
  // faces through the node), no other tet.
  auto cutNode = [&](std::uint32_t v) { return v < onCut.size() && onCut[v] > 0; };
  const bool spike = star_.size() == 1 && boundaryEdges_.size() == 3 &&
                     std::all_of(topology.tet(star_[0]).begin(), topology.tet(star_[0]).end(), cutNode);
  Double3 incentre = from;  // a spike's best place: over its base's incentre (below)
  if (spike) {
    const Tet& t = topology.tet(star_[0]);
    int local = 0;
    while (t[std::size_t(local)] != node) ++local;
    const auto& face = kTetFaces[std::size_t(local)];
    const Double3 a = rest[t[std::size_t(face[0])]], b = rest[t[std::size_t(face[1])]], c = rest[t[std::size_t(face[2])]];
    normal = cross(b - a, c - a);
    const double len = length(normal);
    if (!(len > 0)) return false;
    normal = normal * (1.0 / len);
    // The smallest dihedral angle at a base edge is atan(height / distance of the apex's foot to
    // that edge): largest with the foot at the incentre, where the three distances are equal.
    const double la = length(c - b), lb = length(a - c), lc = length(b - a);
    const Double3 foot = (a * la + b * lb + c * lc) * (1.0 / (la + lb + lc));
    incentre = from + (foot - from) - normal * dot(foot - from, normal);
  } else if (boundaryEdges_.empty()) {
    if (node < onCut.size() && onCut[node] > 0) {
      // Snapped to a cut surface that has not opened here (the crack's front, or a partial
      // split's Steiner side): it may slide parallel to the plane it was snapped to, never
      // towards or away from it.
      if (node >= snapPlane.size()) return false;
      normal = snapPlane[node];
      if (!(std::fabs(length(normal) - 1.0) < 1e-6)) return false;  // none known (0) or two planes (NaN)
      // The plane was taken in the positions the cutter cut in; a slide at rest keeps the
      // distance to it only where the star is undeformed (as when surgery::SoftBody cuts at rest).
      for (std::uint32_t s : star_)
        for (std::uint32_t v : topology.tet(s))
          if (rest[v].x != pos[v].x || rest[v].y != pos[v].y || rest[v].z != pos[v].z) return false;
      planar = true;
    }
    if (vertices + star_.size() != distinctEdges + 2) return false;
  } else {
    if (vertices + star_.size() != distinctEdges + 1) return false;
    rimNodes_.clear();
    for (std::uint64_t e : boundaryEdges_) {
      rimNodes_.push_back(std::uint32_t(e >> 32));
      rimNodes_.push_back(std::uint32_t(e & 0xffffffffu));
    }
    std::sort(rimNodes_.begin(), rimNodes_.end());
    for (std::size_t i = 0; i < rimNodes_.size(); i += 2)
      if (i + 1 >= rimNodes_.size() || rimNodes_[i] != rimNodes_[i + 1] ||
          (i + 2 < rimNodes_.size() && rimNodes_[i + 2] == rimNodes_[i]))
        return false;
    // Every boundary face through the node: its unit normal (outward: from the node's tet side)
    // must agree to kFlatSine (rounding of points computed on a plane) with the first face's, or
    // with a second plane's (a crease), and there may be no third.
    bool first = true;
    Double3 second{0, 0, 0};
    for (std::uint32_t s : star_) {
      const Tet& t = topology.tet(s);
      int local = 0;
      while (t[std::size_t(local)] != node) ++local;
      for (int f = 0; f < 4; ++f) {
        if (f == local) continue;
        const auto& face = kTetFaces[std::size_t(f)];
        std::uint32_t a = kNone, b = kNone;
        for (int c : face)
          if (c != local) (a == kNone ? a : b) = t[std::size_t(c)];
        if (!std::binary_search(boundaryEdges_.begin(), boundaryEdges_.end(), edgeKey(a, b))) continue;
        const Double3 pa = rest[t[std::size_t(face[0])]], pb = rest[t[std::size_t(face[1])]],
                      pc = rest[t[std::size_t(face[2])]];
        Double3 n = cross(pb - pa, pc - pa);
        const double len = length(n);
        if (!(len > 0)) return false;
        n = n * (1.0 / len);
        if (first) {
          normal = n;
          first = false;
        } else if (dot(n, normal) > 0 && length(cross(n, normal)) <= kFlatSine) {
          continue;
        } else if (!crease) {
          second = n;  // a second plane: the node may only slide along the line of both
          crease = true;
          if (length(cross(normal, second)) < kCreaseSine) return false;
        } else if (dot(n, second) <= 0 || length(cross(n, second)) > kFlatSine) {
          return false;
        }
      }
    }
    if (crease) {
      line = cross(normal, second);
      line = line * (1.0 / length(line));
    }
  }
  double current = 1e300;
  std::uint32_t worst = star_[0];
  Double3 centroid{0, 0, 0};
  double edge = 0;
  for (std::uint32_t s : star_) {
    const Tet& t = topology.tet(s);
    const double q = dihedralQuality(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]]);
    if (q < current) current = q, worst = s;
    centroid = centroid + (rest[t[0]] + rest[t[1]] + rest[t[2]] + rest[t[3]]) * 0.25;
    for (std::uint32_t v : t)
      if (v != node) edge += length(rest[v] - from);
  }
  centroid = centroid * (1.0 / double(star_.size()));
  edge /= double(3 * star_.size());
  // Away from the face opposite the node in the worst tet: the direction that opens a sliver.
  const Tet& w = topology.tet(worst);
  int local = 0;
  while (w[std::size_t(local)] != node) ++local;
  const auto& face = kTetFaces[std::size_t(local)];
  const Double3 fa = rest[w[std::size_t(face[0])]], fb = rest[w[std::size_t(face[1])]], fc = rest[w[std::size_t(face[2])]];
  Double3 away = cross(fb - fa, fc - fa);  // kTetFaces are outward: the node is on the inner side
  away = away * (-1.0 / std::max(length(away), 1e-300));
  // A boundary node's candidates are projected into its plane, a crease node's onto its line (a
  // direction: the part of it that keeps the node on its planes).
  auto inPlane = [&](Double3 d) { return crease ? line * dot(d, line) : d - normal * dot(d, normal); };
  const Double3 toCentroid = inPlane(centroid - from);
  Double3 opening = inPlane(away);
  if (planar) opening = opening * (1.0 / std::max(length(opening), 1e-300));
  std::array<Double3, 6> candidates{from + toCentroid,          from + toCentroid * 0.5,
                                    from + toCentroid * 0.25,   from + opening * (0.3 * edge),
                                    from + opening * (0.15 * edge), from + opening * (0.05 * edge)};
  // A spike moves the surface: the shortest step towards the incentre that reaches the threshold
  // (the best of them when none does), so its faces move as little as the angle needs.
  if (spike)
    for (std::size_t i = 0; i < 4; ++i) candidates[i] = from + (incentre - from) * (0.125 * double(1 << i));
  const std::size_t count = spike ? 4 : candidates.size();
  double bestQuality = current + 1e-9;
  const Double3* best = nullptr;
  for (std::size_t k = 0; k < count; ++k) {
    if (spike && bestQuality >= threshold) break;  // the previous, shorter step is enough
    const Double3& to = candidates[k];
    double q = 1e300;
    for (std::uint32_t s : star_) {
      q = std::min(q, qualityAt(rest, topology.tet(s), node, to));
      if (q <= bestQuality) break;
    }
    if (q <= bestQuality) continue;
    bool valid = true;
    for (std::size_t i = 0; i < star_.size() && valid; ++i) valid = positiveAt(rest, topology.tet(star_[i]), node, to);
    if (!valid) continue;
    bestQuality = q;
    best = &to;
  }
  if (best == nullptr) return false;
  // The tet of the star that holds the new position (the largest smallest barycentric weight):
  // its weights carry the move to the current positions, as the FEM will apply it.
  double inside = -1e300;
  for (std::uint32_t s : star_) {
    const Tet& t = topology.tet(s);
    const double volume = tetVolume(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]]);
    std::array<double, 4> b{};
    b[0] = tetVolume(*best, rest[t[1]], rest[t[2]], rest[t[3]]) / volume;
    b[1] = tetVolume(rest[t[0]], *best, rest[t[2]], rest[t[3]]) / volume;
    b[2] = tetVolume(rest[t[0]], rest[t[1]], *best, rest[t[3]]) / volume;
    b[3] = 1.0 - b[0] - b[1] - b[2];
    const double least = *std::min_element(b.begin(), b.end());
    if (least > inside) inside = least, move.sources = t, move.weights = b;
  }
  move.index = node;
  // Rest and current position from the weights, summed in source order (as the FEM sums them).
  Double3 newRest{0, 0, 0}, newPos{0, 0, 0};
  for (std::size_t i = 0; i < 4; ++i) {
    const double wi = move.weights[i];
    const Double3 r = rest[move.sources[i]], p = pos[move.sources[i]];
    newRest = {newRest.x + wi * r.x, newRest.y + wi * r.y, newRest.z + wi * r.z};
    newPos = {newPos.x + wi * p.x, newPos.y + wi * p.y, newPos.z + wi * p.z};
  }
  // The weights' rounding moves the point by ~1e-16: check the star again at what is stored.
  for (std::uint32_t s : star_) {
    const Tet& t = topology.tet(s);
    if (!positiveAt(rest, t, node, newRest) || (&rest != &pos && !positiveAt(pos, t, node, newPos))) return false;
  }
  // The spatial hash needs a tet again only when the node left the tet's box (positions, as the
  // hash boxes them): otherwise the new box lies inside the old one, which its listing covers.
  leftBox_.clear();
  for (std::uint32_t s : star_) {
    const Tet& t = topology.tet(s);
    Double3 lo = pos[t[0]], hi = pos[t[0]];
    for (std::uint32_t v : t) {
      lo = {std::min(lo.x, pos[v].x), std::min(lo.y, pos[v].y), std::min(lo.z, pos[v].z)};
      hi = {std::max(hi.x, pos[v].x), std::max(hi.y, pos[v].y), std::max(hi.z, pos[v].z)};
    }
    const bool inside = newPos.x >= lo.x && newPos.y >= lo.y && newPos.z >= lo.z && newPos.x <= hi.x &&
                        newPos.y <= hi.y && newPos.z <= hi.z;
    leftBox_.push_back(inside ? 0 : 1);
  }
  topology.moveNode(node, newPos, newRest);
  return true;
}

std::size_t NodeSmoothing::improve(CutTopology& topology, SpatialGrid& grid, std::span<const std::uint32_t> seeds,
                                   double belowDeg, const std::vector<double>& onCut,
                                   const std::vector<Double3>& snapPlane, FlipChangeSet change,
                                   std::vector<MovedNode>& moved) {
  if (listed_.size() < topology.slotCount()) listed_.resize(topology.slotCount() + topology.slotCount() / 2, 0);
  for (std::uint32_t s : change.addedTets) listed_[s] = 1;
  const double bar = -std::cos(belowDeg * (3.14159265358979323846 / 180.0));
  std::size_t moves = 0;
  const auto& rest = topology.mesh().restPositions;
  if (tried_.size() < rest.size()) tried_.resize(rest.size() + rest.size() / 2, 0);
  for (std::uint32_t slot : seeds) {
    if (slot >= topology.slotCount() || !topology.alive(slot)) continue;
    const Tet t = topology.tet(slot);
    for (std::uint32_t node : t) {
      if (tried_[node]) continue;
      if (dihedralQuality(rest[t[0]], rest[t[1]], rest[t[2]], rest[t[3]]) >= bar) break;
      tried_[node] = 1;
      triedNodes_.push_back(node);
      MovedNode move;
      if (!tryNode(topology, node, bar, onCut, snapPlane, move)) continue;
      ++moves;
      moved.push_back(move);
      for (std::size_t i = 0; i < star_.size(); ++i) {
        const std::uint32_t s = star_[i];
        if (!listed_[s]) {
          listed_[s] = 1;
          change.removedTets.push_back(s);
          change.removedTetNodes.push_back(topology.tet(s));
          change.addedTets.push_back(s);
        }
        if (leftBox_[i]) grid.insert(topology, s);
      }
    }
  }
  for (std::uint32_t s : change.addedTets) listed_[s] = 0;
  for (std::uint32_t n : triedNodes_) tried_[n] = 0;
  triedNodes_.clear();
  return moves;
}

}  // namespace blobvk::cutting
