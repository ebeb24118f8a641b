#include "blobvk/cutting/cutter.h"

#include "blobvk/cutting/crack_slivers.h"
#include "blobvk/cutting/flat_hash.h"
#include "blobvk/cutting/local_groups.h"
#include "blobvk/cutting/predicates.h"
#include "blobvk/cutting/radix_sort.h"
#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace blobvk::cutting {
namespace {

struct CutEdge {
  std::uint32_t a, b;  // a < b
  double t;            // crossing at a + t (b - a)
};

struct TriBox {
  Double3 lo, hi;
};

TriBox boxOf(const Triangle& t, double pad) {
  TriBox b{t[0], t[0]};
  for (const auto& p : t) {
    b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y), std::min(b.lo.z, p.z)};
    b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y), std::max(b.hi.z, p.z)};
  }
  b.lo = b.lo - Double3{pad, pad, pad};
  b.hi = b.hi + Double3{pad, pad, pad};
  return b;
}

bool overlaps(const TriBox& b, const std::array<Double3, 4>& c) {
  Double3 lo = c[0], hi = c[0];
  for (const Double3& p : c) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return !(hi.x < b.lo.x || hi.y < b.lo.y || hi.z < b.lo.z || lo.x > b.hi.x || lo.y > b.hi.y || lo.z > b.hi.z);
}

bool overlaps(const TriBox& b, Double3 p, Double3 q) {
  return !(std::max(p.x, q.x) < b.lo.x || std::max(p.y, q.y) < b.lo.y || std::max(p.z, q.z) < b.lo.z ||
           std::min(p.x, q.x) > b.hi.x || std::min(p.y, q.y) > b.hi.y || std::min(p.z, q.z) > b.hi.z);
}

double distanceToSurface(Double3 p, const std::vector<Triangle>& swept) {
  double best = 1e300;
  for (const auto& t : swept) best = std::min(best, length(p - closestPointOnTriangle(p, t[0], t[1], t[2])));
  return best;
}

// The plane of the cut surface at p: the unit normal of the swept triangle nearest p; NaN when
// another triangle within `tie` of that distance is not parallel to it (p at a kink of the blade's
// path, where no one plane holds it), zero for a degenerate triangle.
Double3 snapPlaneAt(Double3 p, const std::vector<Triangle>& swept, double tie) {
  auto unitNormal = [](const Triangle& t) {
    const Double3 n = cross(t[1] - t[0], t[2] - t[0]);
    const double len = length(n);
    return len > 0 ? n * (1.0 / len) : Double3{0, 0, 0};
  };
  double best = 1e300;
  const Triangle* nearest = nullptr;
  for (const auto& t : swept) {
    const double d = length(p - closestPointOnTriangle(p, t[0], t[1], t[2]));
    if (d < best) best = d, nearest = &t;
  }
  if (nearest == nullptr) return {0, 0, 0};
  const Double3 normal = unitNormal(*nearest);
  for (const auto& t : swept)
    if (&t != nearest && length(p - closestPointOnTriangle(p, t[0], t[1], t[2])) <= best + tie &&
        length(cross(unitNormal(t), normal)) > 1e-10)
      return {std::nan(""), 0, 0};
  return normal;
}

// Position of node n in tet t, -1 when absent.
int localIndex(const Tet& t, std::uint32_t n) {
  for (int i = 0; i < 4; ++i)
    if (t[std::size_t(i)] == n) return i;
  return -1;
}

// Local edge (kTetEdges numbering) between local nodes i and j.
constexpr std::array<std::array<std::uint8_t, 4>, 4> kLocalEdge = [] {
  std::array<std::array<std::uint8_t, 4>, 4> table{};
  for (std::size_t e = 0; e < 6; ++e) {
    table[std::size_t(kTetEdges[e][0])][std::size_t(kTetEdges[e][1])] = std::uint8_t(e);
    table[std::size_t(kTetEdges[e][1])][std::size_t(kTetEdges[e][0])] = std::uint8_t(e);
  }
  return table;
}();

// Cut codes of one touched tet.
struct Codes {
  std::uint8_t edges = 0, nodes = 0;
};

// Crack opening: node `from` of the tet in `slot` becomes `to`.
struct Rename {
  std::uint32_t slot, from, to;
};

}  // namespace

// Per-event working storage, kept between events so that an event allocates nothing once the
// buffers have grown to the size of the largest event (and touches no fresh pages). Every
// buffer is emptied where it is first used; the hash tables are sized to the event (their
// clear() costs their capacity, i.e. the largest event so far, never the mesh).
struct Cutter::Scratch {
  std::vector<TriBox> boxes;
  std::vector<Double3> normals;
  std::vector<SpatialGrid::Slab> slabs;
  std::vector<std::uint32_t> flipSeeds;
  std::vector<std::uint32_t> candidates, near, order, around, groupSize, copyOfRoot, rootOf, faceTet, usedSlots;
  std::vector<std::uint8_t> relevant;
  std::vector<double> nearPlane, distances;
  std::vector<CutEdge> kept;
  std::vector<FaceKey> crack;
  std::vector<std::uint64_t> crackLinks, renameOrder, sortScratch64;
  std::vector<std::uint32_t> sortScratch32;
  std::vector<Rename> renames;
  std::vector<std::uint8_t> isAdded;  // by slot: listed in addedTets (all 0 between events)
  std::vector<Codes> codesOf;         // by slot: cut codes of a touched tet (all 0 between events)
  std::vector<Codes> orderCodes;      // codes of the touched tets, in `order`
  std::vector<std::uint64_t> faceKeys;
  LocalGroups groups;
  CrackSlivers slivers;
  FlatHashMap<std::uint64_t, CutEdge, U64Hash> cutEdges{kNoEdge};
  FlatHashSet<std::uint64_t, U64Hash> tested{kNoEdge};
  FlatHashSet<std::uint32_t, U32Hash> cutNodes{kNone};
  FlatHashMap<std::uint64_t, std::uint32_t, U64Hash> edgePoint{kNoEdge};
  FlatHashMap<std::uint32_t, double, U32Hash> cutNodeDistance{kNone};  // this event's surface distance of each cut node
};

void Cutter::ScratchDeleter::operator()(Scratch* scratch) const { delete scratch; }

Cutter::Cutter(mesh::TetMesh mesh, CutOptions options) : topology_(std::move(mesh)), options_(options) {
  if (!(options_.snapFraction >= 0.0 && options_.snapFraction < 0.5))
    throw std::invalid_argument("CutOptions::snapFraction must lie in [0, 0.5)");
  if (!(options_.steinerMargin > 0.0 && options_.steinerMargin <= 0.25))
    throw std::invalid_argument("CutOptions::steinerMargin must lie in (0, 0.25]");
  scratch_.reset(new Scratch);
  // Same headroom as the topology's, so the first events do not grow it.
  scratch_->isAdded.assign(topology_.slotCount() + topology_.slotCount() / 2 + 4096, 0);
  scratch_->codesOf.assign(scratch_->isAdded.size(), Codes{});
  grid_.rebuild(topology_);
  meanEdge_ = grid_.cellSize() / 2.0;
  snapReach_.assign(topology_.mesh().nodeCount() + topology_.mesh().nodeCount() / 2 + 4096, 0.0);
  snapPlane_.assign(snapReach_.size(), Double3{0, 0, 0});
}

void Cutter::recordSnapPlane(std::uint32_t node, Double3 normal) {
  if (snapPlane_.size() <= node) snapPlane_.resize(std::max(snapReach_.size(), std::size_t(node) + node / 2 + 1), Double3{0, 0, 0});
  Double3& plane = snapPlane_[node];
  if (std::isnan(plane.x)) return;  // already on two planes: stays
  if (plane.x == 0 && plane.y == 0 && plane.z == 0) {
    plane = normal;
    return;
  }
  // The same plane again (a resweep or a final pass over the same blade): kept; another: the node
  // is where two cut surfaces meet and may not slide in either.
  if (!(length(cross(plane, normal)) <= kSnapPlaneSine) || (normal.x == 0 && normal.y == 0 && normal.z == 0))
    plane = {std::nan(""), 0, 0};
}

CutResult Cutter::cut(const std::vector<Triangle>& swept) {
  const auto start = std::chrono::steady_clock::now();
  CutResult result;
  if (swept.empty()) return result;
  if (grid_.needsRebuild(topology_)) grid_.rebuild(topology_);
  const std::size_t slotsBefore = topology_.slotCount();  // the FEM's tet count
  const auto& pos = topology_.mesh().positions;
  const double tolAbs = options_.onSurfaceTolerance * meanEdge_;
  const double tau = options_.snapFraction;
  const double diagonalCosine = options_.crackDiagonalBelowDeg > 0
                                    ? std::cos(options_.crackDiagonalBelowDeg * (3.14159265358979323846 / 180.0))
                                    : 0.0;

  // 1. Candidate tets near the swept surface: those registered in the spatial-hash cells that
  // the triangles' planes cross inside the triangles' boxes.
  Scratch& scratch = *scratch_;
  auto& boxes = scratch.boxes;
  boxes.clear();
  // Unit normals of the swept triangles: a tet strictly on one side of every triangle's plane
  // (farther than the on-surface tolerance) can neither be crossed nor touch the surface.
  auto& normals = scratch.normals;
  auto& slabs = scratch.slabs;
  normals.clear();
  slabs.clear();
  for (const auto& t : swept) {
    boxes.push_back(boxOf(t, tolAbs));
    const Double3 n = cross(t[1] - t[0], t[2] - t[0]);
    normals.push_back(n * (1.0 / length(n)));
    slabs.push_back(SpatialGrid::slabAround(t, tolAbs));
  }
  auto& candidates = scratch.candidates;
  candidates.clear();
  grid_.querySlabs(topology_, slabs, candidates);

  auto lap = [&, last = start](int phase) mutable {
    const auto now = std::chrono::steady_clock::now();
    result.phaseSeconds[std::size_t(phase)] += std::chrono::duration<double>(now - last).count();
    last = now;
  };
  lap(0);

  // 2. Cut edges (each mesh edge tested once) and nodes lying on the surface.
  // Flat open-addressing tables sized to this event (never to the mesh).
  auto& cutEdges = scratch.cutEdges;
  auto& tested = scratch.tested;
  auto& cutNodes = scratch.cutNodes;
  cutEdges.clear();
  tested.clear();
  cutNodes.clear();
  cutEdges.reserve(candidates.size());
  tested.reserve(2 * candidates.size());
  cutNodes.reserve(candidates.size());
  auto& near = scratch.near;
  auto& relevant = scratch.relevant;
  near.clear();
  relevant.assign(swept.size(), 0);
  // Rounding slack of the plane distances below, per triangle: the computed unit normal's
  // direction is off by ~eps / sin(smallest angle of the triangle) and the points lie within
  // `extent` of the origin. A node within tolAbs of the surface is within tolAbs of some
  // triangle's plane, and a segment crossing a triangle has its ends on opposite sides of its
  // plane, so distances beyond tolAbs + slack settle both questions without exact tests.
  double extent = meanEdge_;
  for (const TriBox& b : boxes)
    extent = std::max({extent, std::fabs(b.lo.x), std::fabs(b.lo.y), std::fabs(b.lo.z), std::fabs(b.hi.x),
                       std::fabs(b.hi.y), std::fabs(b.hi.z)});
  auto& nearPlane = scratch.nearPlane;
  auto& distances = scratch.distances;
  nearPlane.assign(swept.size(), 0.0);
  distances.assign(4 * swept.size(), 0.0);
  for (std::size_t i = 0; i < swept.size(); ++i) {
    const Double3 e1 = swept[i][1] - swept[i][0], e2 = swept[i][2] - swept[i][0];
    const double sine = length(cross(e1, e2)) / (length(e1) * length(e2));
    nearPlane[i] = tolAbs + 1e-12 * extent + 16.0 * 2.3e-16 * extent / sine;
  }
  for (std::uint32_t slot : candidates) {
    const Tet& tet = topology_.tet(slot);
    bool any = false;
    const std::array<Double3, 4> corners{pos[tet[0]], pos[tet[1]], pos[tet[2]], pos[tet[3]]};
    unsigned onPlane = 0;  // bit c: corner c lies within nearPlane of some triangle's plane
    std::array<double, 4> planeDistance{1e300, 1e300, 1e300, 1e300};  // nearest triangle plane, by corner
    for (std::size_t i = 0; i < swept.size(); ++i) {
      int above = 0, below = 0;
      for (std::size_t c = 0; c < 4; ++c) {
        const double d = distances[4 * i + c] = dot(corners[c] - swept[i][0], normals[i]);
        above += d > tolAbs;
        below += d < -tolAbs;
        onPlane |= unsigned(std::fabs(d) <= nearPlane[i]) << c;
        planeDistance[c] = std::min(planeDistance[c], std::fabs(d) - (nearPlane[i] - tolAbs));
      }
      // A triangle matters to the tet when the tet straddles its plane and meets its box.
      relevant[i] = above < 4 && below < 4 && overlaps(boxes[i], corners);
      any |= relevant[i] != 0;
    }
    if (!any) continue;
    near.push_back(slot);
    for (const auto& e : kTetEdges) {
      std::uint32_t a = tet[e[0]], b = tet[e[1]];
      if (a > b) std::swap(a, b);
      // Irrelevant triangles have both ends of every edge of the tet on one side, so one test
      // per edge (against the triangles relevant to the first tet that reaches it) is exact.
      if (!tested.insert(edgeKey(a, b))) continue;
      bool hitAny = false;
      for (std::size_t i = 0; i < swept.size() && !hitAny; ++i) {
        if (!relevant[i]) continue;
        const double da = distances[4 * i + std::size_t(e[0])], db = distances[4 * i + std::size_t(e[1])];
        if ((da > nearPlane[i] && db > nearPlane[i]) || (da < -nearPlane[i] && db < -nearPlane[i])) continue;
        if (!overlaps(boxes[i], pos[a], pos[b])) continue;
        // A distance beyond the slack fixes that end's orientation sign (opposite to the distance's).
        auto sideOf = [&](double d) { return d > nearPlane[i] ? -1 : (d < -nearPlane[i] ? 1 : 0); };
        const bool swapped = tet[e[0]] > tet[e[1]];  // a, b are the edge's ends in ascending order
        const SegmentHit hit = segmentCrossesTriangle(pos[a], pos[b], swept[i][0], swept[i][1], swept[i][2],
                                                      sideOf(swapped ? db : da), sideOf(swapped ? da : db));
        if (hit.hit) {
          cutEdges.insert(edgeKey(a, b), CutEdge{a, b, hit.t});
          hitAny = true;
        }
      }
    }
    for (std::size_t c = 0; c < 4; ++c) {
      // A node the crack was snapped to earlier is on the surface again while within its reach.
      const double reach = tolAbs + (tet[c] < snapReach_.size() ? snapReach_[tet[c]] : 0.0);
      if (((onPlane >> c & 1) || planeDistance[c] <= reach) && !cutNodes.contains(tet[c]) &&
          distanceToSurface(corners[c], swept) <= reach)
        cutNodes.insert(tet[c]);
    }
  }

  result.candidateTets = near.size();

  // 3. Cut nodes by the thesis' rule, then drop every cut edge touching a cut node.
  cutEdges.forEach([&](std::uint64_t, const CutEdge& ce) {
    if (ce.t < tau) cutNodes.insert(ce.a);
    if (ce.t > 1.0 - tau) cutNodes.insert(ce.b);
  });
  // Remember how far from the surface each cut node is (kept for later events, see snapReach_).
  if (snapReach_.size() < pos.size()) snapReach_.resize(pos.size() + pos.size() / 2, 0.0);
  // The distances are kept for the crack faces of step 6 (every node of such a face is a cut node).
  auto& cutNodeDistance = scratch.cutNodeDistance;
  cutNodeDistance.clear();
  cutNodeDistance.reserve(cutNodes.size());
  cutNodes.forEach([&](std::uint32_t n) {
    const double distance = distanceToSurface(pos[n], swept);
    cutNodeDistance.insert(n, distance);
    snapReach_[n] = std::max(snapReach_[n], distance);
    recordSnapPlane(n, snapPlaneAt(pos[n], swept, tolAbs));
  });
  auto& kept = scratch.kept;
  kept.clear();
  cutEdges.forEach([&](std::uint64_t, const CutEdge& ce) {
    if (!cutNodes.contains(ce.a) && !cutNodes.contains(ce.b)) kept.push_back(ce);
  });
  std::sort(kept.begin(), kept.end(), [](const CutEdge& x, const CutEdge& y) {
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  result.cutEdges = kept.size();
  result.cutNodes = cutNodes.size();

  lap(1);

  auto markOnCut = [&](std::uint32_t node, double reach) {
    if (snapReach_.size() <= node) snapReach_.resize(node + node / 2 + 1, 0.0);
    snapReach_[node] = std::max(snapReach_[node], reach);
  };

  // 4. Codes per touched tet, in a per-slot array (zero between events; no hash probes) and the
  // list of touched slots (`order`, a slot joins it when its codes first become non-zero).
  auto& codesOf = scratch.codesOf;
  if (codesOf.size() < topology_.slotCount()) codesOf.resize(topology_.slotCount() + topology_.slotCount() / 2);
  auto& order = scratch.order;
  order.clear();
  auto touch = [&](std::uint32_t slot) -> Codes& {
    Codes& codes = codesOf[slot];
    if ((codes.edges | codes.nodes) == 0) order.push_back(slot);
    return codes;
  };
  auto& edgePoint = scratch.edgePoint;
  edgePoint.clear();
  edgePoint.reserve(kept.size());
  for (const CutEdge& ce : kept) {
    const std::uint32_t node = topology_.addNode(lerp(topology_.mesh().positions[ce.a], topology_.mesh().positions[ce.b], ce.t),
                                                 lerp(topology_.mesh().restPositions[ce.a],
                                                      topology_.mesh().restPositions[ce.b], ce.t));
    edgePoint.insert(edgeKey(ce.a, ce.b), node);
    markOnCut(node, tolAbs);
    recordSnapPlane(node, snapPlaneAt(topology_.mesh().positions[node], swept, tolAbs));
    NewNode nn;
    nn.index = node;
    nn.kind = NewNode::Kind::EdgePoint;
    nn.sources = {ce.a, ce.b, kNone, kNone};
    nn.weights = {1.0 - ce.t, ce.t, 0.0, 0.0};
    result.newNodes.push_back(nn);
    for (std::uint32_t slot : topology_.tetsOfNode(ce.a)) {
      const Tet& tet = topology_.tet(slot);
      const int j = localIndex(tet, ce.b);
      if (j < 0) continue;
      const int i = localIndex(tet, ce.a);
      touch(slot).edges |= std::uint8_t(1u << kLocalEdge[std::size_t(i)][std::size_t(j)]);
    }
  }
  cutNodes.forEach([&](std::uint32_t n) {
    for (std::uint32_t slot : topology_.tetsOfNode(n)) {
      const Tet& tet = topology_.tet(slot);
      for (int i = 0; i < 4; ++i)
        if (tet[i] == n) touch(slot).nodes |= std::uint8_t(1u << i);
    }
  });
  radixSort(order, scratch.sortScratch32, std::uint32_t(topology_.slotCount()), [](std::uint32_t x) { return x; });
  // The codes move out of the per-slot array (left all zero for the next event).
  auto& orderCodes = scratch.orderCodes;
  orderCodes.clear();
  for (std::uint32_t slot : order) orderCodes.push_back(std::exchange(codesOf[slot], Codes{}));
  // About 4.5 children per split and 1-2 new nodes per cut edge (sizes of the change set).
  result.removedTets.reserve(2 * order.size());
  result.removedTetNodes.reserve(2 * order.size());
  result.addedTets.reserve(6 * order.size());
  result.newNodes.reserve(2 * kept.size() + order.size());

  // 5. Split, 6. collect crack faces.
  auto& crack = scratch.crack;  // sorted and made unique after the splits
  crack.clear();
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::uint32_t slot = order[k];
    const Codes codes = orderCodes[k];
    const Tet parent = topology_.tet(slot);
    if (codes.edges == 0) {
      const CutCase kind = std::popcount(unsigned(codes.nodes)) >= 3 ? CutCase::Z : CutCase::NodesOnly;
      ++result.caseCounts[std::size_t(kind)];
      if (kind != CutCase::Z) continue;
      // A face of three cut nodes is on the crack where the surface really separates the two
      // tets sharing it: each tet's side is that of its solid (non-cut) nodes against the swept
      // triangle nearest the face, or of its centroid against the triangle nearest the centroid
      // when all four nodes are cut nodes.
      for (const auto& f : kTetFaces) {
        if (!(codes.nodes >> f[0] & 1) || !(codes.nodes >> f[1] & 1) || !(codes.nodes >> f[2] & 1)) continue;
        const std::uint32_t a = parent[f[0]], b = parent[f[1]], c = parent[f[2]];
        const auto pair = topology_.tetsOfFace(a, b, c);
        const std::uint32_t other = pair[0] == slot ? pair[1] : pair[0];
        if (other == kNone) continue;
        // Everything below is the face's and the pair's, not the order of the two tets: a face
        // whose other tet came earlier in `order` with three cut nodes on it was settled there.
        if (other < slot) {
          const auto it = std::lower_bound(order.begin(), order.begin() + std::ptrdiff_t(k), other);
          if (it != order.begin() + std::ptrdiff_t(k) && *it == other) {
            const Codes& otherCodes = orderCodes[std::size_t(it - order.begin())];
            if (otherCodes.edges == 0 && std::popcount(unsigned(otherCodes.nodes)) >= 3) continue;
          }
        }
        const Double3 centre = (pos[a] + pos[b] + pos[c]) * (1.0 / 3.0);
        const Triangle* nearest = nullptr;
        double nearestDistance = 1e300;
        for (const auto& tri : swept) {
          const double dist = length(centre - closestPointOnTriangle(centre, tri[0], tri[1], tri[2]));
          if (dist < nearestDistance) nearestDistance = dist, nearest = &tri;
        }
        // Beyond the blade the face would drift off the surface: its centre may be no farther
        // than its farthest (snapped) node, plus tau of its size where the surface bends.
        const double reach =
            std::max({*cutNodeDistance.find(a), *cutNodeDistance.find(b), *cutNodeDistance.find(c)});
        const double span = std::max({length(pos[b] - pos[a]), length(pos[c] - pos[b]), length(pos[a] - pos[c])});
        if (nearestDistance > reach + tau * span + tolAbs) continue;
        const Triangle& plane = *nearest;
        auto sideOf = [&](std::uint32_t t) {
          const Tet& nodes = topology_.tet(t);
          double best = 0.0;
          for (std::uint32_t v : nodes)
            if (!cutNodes.contains(v)) {
              const double value = orient3dValue(plane[0], plane[1], plane[2], pos[v]);
              if (std::fabs(value) > std::fabs(best)) best = value;
            }
          if (best == 0.0) {
            // A tet with four cut nodes lies flat on the surface and has several such faces: its
            // side must be one answer for all of them, so it is its centroid's side of the
            // triangle nearest that centroid, not of each face's nearest triangle (on a curved
            // stroke two triangles' planes can disagree, and the crack then passed on neither
            // side of the tet: the craniotomy's flap stayed attached by it).
            const Double3 centroid = (pos[nodes[0]] + pos[nodes[1]] + pos[nodes[2]] + pos[nodes[3]]) * 0.25;
            const Triangle* own = &plane;
            double ownDistance = 1e300;
            for (const auto& tri : swept) {
              const double dist = length(centroid - closestPointOnTriangle(centroid, tri[0], tri[1], tri[2]));
              if (dist < ownDistance) ownDistance = dist, own = &tri;
            }
            best = orient3dValue((*own)[0], (*own)[1], (*own)[2], centroid);
          }
          return best > 0 ? 1 : (best < 0 ? -1 : 0);
        };
        if (sideOf(slot) * sideOf(other) < 0) crack.push_back(makeFaceKey(a, b, c));
      }
      continue;
    }
    std::array<std::uint32_t, 11> global{};
    std::array<std::uint64_t, 11> keys{};
    for (int i = 0; i < 4; ++i) global[i] = parent[i], keys[i] = parent[i];
    for (int e = 0; e < 6; ++e) {
      keys[kEdgePointBase + e] = ~0ull - 1;
      if (codes.edges >> e & 1) {
        global[kEdgePointBase + e] = *edgePoint.find(edgeKey(parent[kTetEdges[e][0]], parent[kTetEdges[e][1]]));
        keys[kEdgePointBase + e] = global[kEdgePointBase + e];
      }
    }
    keys[kSteinerLocal] = ~0ull;
    const auto& rest = topology_.mesh().restPositions;
    auto steinerWeights = [&](const Tet& t, const std::vector<Triangle>& surface) -> std::array<double, 4> {
      const auto& p = topology_.mesh().positions;
      const Double3 centroid = (p[t[0]] + p[t[1]] + p[t[2]] + p[t[3]]) * 0.25;
      Double3 best = centroid;
      double bestDistance = 1e300;
      for (const auto& tri : surface) {
        const Double3 q = closestPointOnTriangle(centroid, tri[0], tri[1], tri[2]);
        if (length(q - centroid) < bestDistance) bestDistance = length(q - centroid), best = q;
      }
      const double volume = tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
      std::array<double, 4> w{};
      if (volume > 0) {
        w[0] = tetVolume(best, p[t[1]], p[t[2]], p[t[3]]) / volume;
        w[1] = tetVolume(p[t[0]], best, p[t[2]], p[t[3]]) / volume;
        w[2] = tetVolume(p[t[0]], p[t[1]], best, p[t[3]]) / volume;
        w[3] = 1.0 - w[0] - w[1] - w[2];
        if (*std::min_element(w.begin(), w.end()) >= options_.steinerMargin) return w;
      }
      return {0.25, 0.25, 0.25, 0.25};
    };
    const double parentRest = tetVolume(rest[parent[0]], rest[parent[1]], rest[parent[2]], rest[parent[3]]);
    // Steiner point of a partial split: the centroid's closest point on the swept surface when
    // it lies inside the tet with every barycentric weight >= steinerMargin (the crack then
    // continues through it exactly when the blade moves on), else the centroid.
    // Computed on first use: most splits in a sweep are separating and need no Steiner point.
    std::array<double, 4> lambda{};
    bool haveLambda = false;
    auto restOf = [&](std::uint8_t local) -> Double3 {
      if (local == kSteinerLocal && !haveLambda) lambda = steinerWeights(parent, swept), haveLambda = true;
      if (local == kSteinerLocal)
        return rest[parent[0]] * lambda[0] + rest[parent[1]] * lambda[1] + rest[parent[2]] * lambda[2] +
               rest[parent[3]] * lambda[3];
      return rest[global[local]];
    };
    auto minRatio = [&](const Decomposition& d) {
      double worst = 1e300;
      for (int i = 0; i < d.tetCount; ++i) {
        const auto& c = d.tets[i];
        worst = std::min(worst, tetVolume(restOf(c[0]), restOf(c[1]), restOf(c[2]), restOf(c[3])) / parentRest);
      }
      return worst;
    };
    const Decomposition* decomposition = &decompositions_.get(codes.edges, codes.nodes, keys);
    double ratio = minRatio(*decomposition);
    if (decomposition->kind == CutCase::B && diagonalCosine > 0) {
      // A quad crack is fanned from its smallest-key cut point; that diagonal is the key rule's
      // only free choice (every other polygon of a quad slice is fanned from an existing node,
      // whose key is below every cut point's), and neither neighbours nor the faces see it. When
      // it leaves a child below crackDiagonalBelowDeg, the other diagonal is taken if its worst
      // child is better: the quad of three nearly collinear cut points otherwise makes a flat
      // crack triangle, and the cones over it the flattest tets of a stroke.
      auto worstChild = [&](const Decomposition& d) {
        double worst = 1.0;
        for (int i = 0; i < d.tetCount; ++i) {
          const auto& c = d.tets[i];
          worst = std::min(worst, dihedralQuality(restOf(c[0]), restOf(c[1]), restOf(c[2]), restOf(c[3])));
        }
        return worst;
      };
      const double quality = worstChild(*decomposition);
      if (quality < -diagonalCosine) {
        // The other diagonal: the smallest key moves to a quad neighbour of its cut point (a cut
        // edge sharing a node with it; the opposite one shares none).
        int smallest = -1;
        for (int e = 0; e < 6; ++e)
          if ((codes.edges >> e & 1) && (smallest < 0 || keys[kEdgePointBase + e] < keys[kEdgePointBase + smallest]))
            smallest = e;
        int neighbour = -1;
        for (int e = 0; e < 6 && neighbour < 0; ++e)
          if (e != smallest && (codes.edges >> e & 1) &&
              (kTetEdges[e][0] == kTetEdges[smallest][0] || kTetEdges[e][0] == kTetEdges[smallest][1] ||
               kTetEdges[e][1] == kTetEdges[smallest][0] || kTetEdges[e][1] == kTetEdges[smallest][1]))
            neighbour = e;
        std::array<std::uint64_t, 11> otherKeys = keys;
        std::swap(otherKeys[kEdgePointBase + smallest], otherKeys[kEdgePointBase + neighbour]);
        const Decomposition& other = decompositions_.get(codes.edges, codes.nodes, otherKeys);
        const double otherRatio = minRatio(other);
        if (otherRatio > 1e-12 && worstChild(other) > quality) decomposition = &other, ratio = otherRatio;
        else decomposition = &decompositions_.get(codes.edges, codes.nodes, keys);  // a hit: `other` may have moved it
      }
    }
    if (decomposition->separating && !(ratio > 1e-12)) {
      // A strongly non-planar crack quad would invert a child: split without opening instead.
      decomposition = &decompositions_.get(codes.edges, codes.nodes, keys, true);
      ratio = minRatio(*decomposition);
      ++result.separatingFallbacks;
    }
    const Decomposition& d = *decomposition;
    ++result.caseCounts[std::size_t(d.kind)];
    result.minChildVolumeRatio = std::min(result.minChildVolumeRatio, ratio);
    if (d.usesSteiner) {
      const auto& p = topology_.mesh().positions;
      const Double3 steinerRest = restOf(kSteinerLocal);  // also sets lambda
      global[kSteinerLocal] = topology_.addNode(p[parent[0]] * lambda[0] + p[parent[1]] * lambda[1] +
                                                    p[parent[2]] * lambda[2] + p[parent[3]] * lambda[3],
                                                steinerRest);
      NewNode nn;
      nn.index = global[kSteinerLocal];
      nn.kind = NewNode::Kind::Steiner;
      if (lambda != std::array<double, 4>{0.25, 0.25, 0.25, 0.25}) {  // on the surface
        markOnCut(global[kSteinerLocal], tolAbs);
        recordSnapPlane(global[kSteinerLocal], snapPlaneAt(p[global[kSteinerLocal]], swept, tolAbs));
      }
      nn.sources = parent;
      nn.weights = lambda;
      result.newNodes.push_back(nn);
    }
    result.removedTets.push_back(slot);
    result.removedTetNodes.push_back(parent);
    ++result.splitTets;
    const std::uint32_t region = topology_.mesh().regions[slot];
    for (int i = 0; i < d.tetCount; ++i) {
      const auto& c = d.tets[i];
      const Tet child{global[c[0]], global[c[1]], global[c[2]], global[c[3]]};
      std::uint32_t s = slot;
      if (i == 0) topology_.setTet(slot, child);
      else s = topology_.addTet(child, region);
      result.addedTets.push_back(s);
    }
    // Every child lies inside the parent's box: the first shrinks the parent slot's box, the
    // others join the parent slot's family (no spatial-hash entries of their own).
    grid_.shrink(topology_, slot, parent);
    grid_.cover(topology_, std::span<const std::uint32_t>(result.addedTets).last(std::size_t(d.tetCount - 1)), slot,
                parent);
    for (int i = 0; i < d.crackCount; ++i)
      crack.push_back(makeFaceKey(global[d.crack[i][0]], global[d.crack[i][1]], global[d.crack[i][2]]));
  }
  auto faceLess = [](const FaceKey& x, const FaceKey& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.c < y.c);
  };
  std::sort(crack.begin(), crack.end(), faceLess);
  crack.erase(std::unique(crack.begin(), crack.end()), crack.end());
  // Nodes on a cut surface (cut points, snapped nodes) are marked in snapReach_ (> 0).
  result.attachedSlivers = scratch.slivers.attach(topology_, crack, snapReach_);
  result.crackFaces = crack.size();

  lap(2);

  // 7. Open the crack: around each crack vertex, tets connected through non-crack faces stay
  // together; every further group gets its own copy of the vertex. All groups are found on the
  // topology before any renumbering, then each tet is rewritten once: two tets glued by a
  // non-crack face lie in the same group around each of that face's vertices, so they receive
  // the same copies and stay glued, whatever the order of the vertices.
  // The crack faces through each vertex, packed (vertex << 32 | crack face index) and sorted
  // (integers: a cheaper sort than records compared field by field): the faces through v are
  // then one short run (a few entries) to scan.
  auto& crackLinks = scratch.crackLinks;
  crackLinks.clear();
  crackLinks.reserve(3 * crack.size());
  for (std::size_t i = 0; i < crack.size(); ++i) {
    const FaceKey& f = crack[i];
    crackLinks.push_back(std::uint64_t(f.a) << 32 | i);
    crackLinks.push_back(std::uint64_t(f.b) << 32 | i);
    crackLinks.push_back(std::uint64_t(f.c) << 32 | i);
  }
  // By vertex; stable, and the links were pushed in face order: sorted as integers.
  radixSort(crackLinks, scratch.sortScratch64, std::uint32_t(topology_.mesh().positions.size()),
            [](std::uint64_t link) { return std::uint32_t(link >> 32); });
  // The crack face of a link as the edge of its two nodes other than the link's vertex.
  auto linkEdge = [&](std::uint64_t link) {
    const FaceKey& f = crack[std::uint32_t(link)];
    const std::uint32_t v = std::uint32_t(link >> 32);
    return v == f.a ? edgeKey(f.b, f.c) : (v == f.b ? edgeKey(f.a, f.c) : edgeKey(f.a, f.b));
  };
  auto& renames = scratch.renames;
  renames.clear();
  auto& around = scratch.around;
  auto& groupSize = scratch.groupSize;
  auto& copyOfRoot = scratch.copyOfRoot;
  auto& rootOf = scratch.rootOf;
  // Face matching around one vertex: an open-addressing table keyed by the edge of the face's
  // two other nodes, holding the first tet seen with it (cleared slot by slot after each vertex).
  auto& faceKeys = scratch.faceKeys;  // all kNoEdge between vertices (and events)
  auto& faceTet = scratch.faceTet;
  auto& usedSlots = scratch.usedSlots;
  auto& groups = scratch.groups;
  for (std::size_t run = 0; run < crackLinks.size();) {
    const std::uint32_t v = std::uint32_t(crackLinks[run] >> 32);
    std::size_t runEnd = run;
    while (runEnd < crackLinks.size() && std::uint32_t(crackLinks[runEnd] >> 32) == v) ++runEnd;
    const std::size_t linksBegin = run, linksEnd = runEnd;
    run = runEnd;

    const auto incident = topology_.tetsOfNode(v);
    if (incident.size() < 2) continue;
    around.assign(incident.begin(), incident.end());
    std::size_t capacity = 16;
    int bits = 4;
    while (capacity < 2 * (3 * around.size() + (linksEnd - linksBegin))) capacity *= 2, ++bits;
    if (faceKeys.size() < capacity) faceKeys.assign(capacity, kNoEdge), faceTet.assign(capacity, 0);
    const std::size_t mask = capacity - 1;
    groups.reset(around.size());
    // The slot of a face key in the table: its entry, or the free slot where it belongs. A
    // multiplicative (Fibonacci) hash: a few dozen keys, and the table is at most half full.
    auto slotOf = [&](std::uint64_t edge) {
      std::size_t h = std::size_t((edge * 0x9E3779B97F4A7C15ull) >> (64 - bits));
      while (faceKeys[h] != kNoEdge && faceKeys[h] != edge) h = (h + 1) & mask;
      return h;
    };
    // Crack faces through v first, marked so that no tet is glued across them.
    for (std::size_t k = linksBegin; k < linksEnd; ++k) {
      const std::uint64_t edge = linkEdge(crackLinks[k]);
      const std::size_t h = slotOf(edge);
      if (faceKeys[h] == kNoEdge) usedSlots.push_back(std::uint32_t(h));
      faceKeys[h] = edge;
      faceTet[h] = kNone;
    }
    // Two tets around v are glued when they share a non-crack face through v, i.e. the same two
    // other nodes: matched locally, no global face lookups.
    for (std::size_t i = 0; i < around.size(); ++i) {
      const Tet& t = topology_.tet(around[i]);
      // v's list holds only tets with v (a tet repeating v is a caller error selfCheck reports).
      const int j = std::max(localIndex(t, v), 0);
      const std::array<std::uint32_t, 3> others{t[std::size_t((j + 1) & 3)], t[std::size_t((j + 2) & 3)],
                                                t[std::size_t((j + 3) & 3)]};
      for (const auto& [x, y] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
        const std::uint64_t edge = edgeKey(others[std::size_t(x)], others[std::size_t(y)]);
        const std::size_t h = slotOf(edge);
        if (faceKeys[h] == kNoEdge) {
          faceKeys[h] = edge;
          faceTet[h] = std::uint32_t(i);
          usedSlots.push_back(std::uint32_t(h));
        } else if (faceTet[h] != kNone) {
          groups.link(faceTet[h], std::uint32_t(i));
        }
      }
    }
    for (std::uint32_t h : usedSlots) faceKeys[h] = kNoEdge;
    usedSlots.clear();
    groups.roots(rootOf);
    // The largest group keeps the vertex (fewest tets renumbered); among equals, the group of
    // the first tet in the vertex's list (a rule that does not depend on union-find roots).
    groupSize.assign(around.size(), 0);
    for (std::size_t i = 0; i < around.size(); ++i) ++groupSize[rootOf[i]];
    std::size_t keep = rootOf[0];
    for (std::size_t i = 1; i < around.size(); ++i)
      if (groupSize[rootOf[i]] > groupSize[keep]) keep = rootOf[i];
    copyOfRoot.assign(around.size(), kNone);
    for (std::size_t i = 0; i < around.size(); ++i) {
      const std::size_t root = rootOf[i];
      if (root == keep) continue;
      if (copyOfRoot[root] == kNone) {
        copyOfRoot[root] = topology_.addNode(topology_.mesh().positions[v], topology_.mesh().restPositions[v]);
        NewNode nn;
        nn.index = copyOfRoot[root];
        nn.kind = NewNode::Kind::Duplicate;
        nn.sources = {v, kNone, kNone, kNone};
        nn.weights = {1.0, 0.0, 0.0, 0.0};
        result.newNodes.push_back(nn);
        ++result.duplicatedNodes;
        markOnCut(copyOfRoot[root], v < snapReach_.size() ? snapReach_[v] : 0.0);
        if (snapPlane_.size() < snapReach_.size()) snapPlane_.resize(snapReach_.size(), Double3{0, 0, 0});
        snapPlane_[copyOfRoot[root]] = v < snapPlane_.size() ? snapPlane_[v] : Double3{std::nan(""), 0, 0};
      }
      renames.push_back({around[i], v, copyOfRoot[root]});
    }
  }
  // Renames in slot order, as packed (slot << 32 | rename index) integers. The renames of one
  // slot commute (each renames a different node to a fresh one).
  auto& renameOrder = scratch.renameOrder;
  renameOrder.clear();
  for (std::size_t i = 0; i < renames.size(); ++i) renameOrder.push_back(std::uint64_t(renames[i].slot) << 32 | i);
  radixSort(renameOrder, scratch.sortScratch64, std::uint32_t(topology_.slotCount()),
            [](std::uint64_t entry) { return std::uint32_t(entry >> 32); });
  // Renumbered tets that were not split are reported as removed (with their nodes before the
  // opening) and re-added. Split children are marked in a per-slot byte array (grown with the
  // mesh, reset entry by entry below, so an event costs its own size).
  auto& isAdded = scratch.isAdded;
  if (isAdded.size() < topology_.slotCount()) isAdded.resize(topology_.slotCount() + topology_.slotCount() / 2, 0);
  const std::size_t splitAdded = result.addedTets.size();
  for (std::uint32_t slot : result.addedTets) isAdded[slot] = 1;
  for (std::size_t i = 0; i < renameOrder.size();) {
    const std::uint32_t slot = std::uint32_t(renameOrder[i] >> 32);
    const Tet before = topology_.tet(slot);
    Tet after = before;
    for (; i < renameOrder.size() && std::uint32_t(renameOrder[i] >> 32) == slot; ++i) {
      const Rename& r = renames[std::uint32_t(renameOrder[i])];
      for (auto& n : after)
        if (n == r.from) n = r.to;
    }
    topology_.setTet(slot, after);
    if (isAdded[slot]) continue;
    result.removedTets.push_back(slot);
    result.removedTetNodes.push_back(before);
    result.addedTets.push_back(slot);
  }
  for (std::size_t i = 0; i < splitAdded; ++i) isAdded[result.addedTets[i]] = 0;
  lap(3);

  // 8. Flips around what the event wrote, now that the crack faces are boundary faces (no flip
  // can cross them). At most two attempts per written tet bound the cost.
  if (options_.improveBelowDeg > 0 && !result.addedTets.empty()) {
    const auto flipStart = std::chrono::steady_clock::now();
    auto& seeds = scratch.flipSeeds;
    seeds.assign(result.addedTets.begin(), result.addedTets.end());
    radixSort(seeds, scratch.sortScratch32, std::uint32_t(topology_.slotCount()), [](std::uint32_t x) { return x; });
    seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
    const FlipStats flips = flips_.improve(topology_, grid_, seeds, options_.improveBelowDeg, 2 * seeds.size() + 16,
                                           slotsBefore, {result.removedTets, result.removedTetNodes, result.addedTets});
    result.faceRemovals = flips.faceRemovals;
    result.edgeRemovals = flips.edgeRemovals;
    result.flipAttempts = flips.attempts;
    if (options_.smoothBelowDeg > 0) {
      seeds.assign(result.addedTets.begin(), result.addedTets.end());
      std::sort(seeds.begin(), seeds.end());
      seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
      if (snapPlane_.size() < snapReach_.size()) snapPlane_.resize(snapReach_.size(), Double3{0, 0, 0});
      smoothing_.improve(topology_, grid_, seeds, options_.smoothBelowDeg, snapReach_, snapPlane_,
                         {result.removedTets, result.removedTetNodes, result.addedTets}, result.movedNodes);
    }
    result.flipSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - flipStart).count();
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

double minimumChildVolumeFraction(double tau, double steinerMargin) {
  // Unit reference tet; the ratio is affine-invariant, so this bounds every tet.
  const std::array<Double3, 4> corner{Double3{0, 0, 0}, Double3{1, 0, 0}, Double3{0, 1, 0}, Double3{0, 0, 1}};
  const double parent = tetVolume(corner[0], corner[1], corner[2], corner[3]);
  double worst = 1.0;
  std::array<int, 4> perm{0, 1, 2, 3};
  for (int nodeMask = 0; nodeMask < 16; ++nodeMask)
    for (int edgeMask = 1; edgeMask < 64; ++edgeMask) {
      bool valid = true;
      for (int e = 0; e < 6; ++e)
        if ((edgeMask >> e & 1) && ((nodeMask >> kTetEdges[e][0] & 1) || (nodeMask >> kTetEdges[e][1] & 1)))
          valid = false;
      if (!valid) continue;
      std::sort(perm.begin(), perm.end());
      do {
        std::array<std::uint64_t, 11> keys{};
        for (int i = 0; i < 4; ++i) keys[i] = std::uint64_t(perm[i]);
        for (int e = 0; e < 6; ++e) keys[kEdgePointBase + e] = 10 + std::uint64_t(e);
        keys[kSteinerLocal] = 100;
        const Decomposition d = decomposeTet(std::uint8_t(edgeMask), std::uint8_t(nodeMask), keys);
        for (int box = 0; box < 64; ++box) {
          std::array<Double3, 11> p{};
          for (int i = 0; i < 4; ++i) p[i] = corner[i];
          for (int e = 0; e < 6; ++e) {
            const double t = (box >> e & 1) ? 1.0 - tau : tau;
            p[kEdgePointBase + e] = lerp(corner[kTetEdges[e][0]], corner[kTetEdges[e][1]], t);
          }
          p[kSteinerLocal] = (corner[0] + corner[1] + corner[2] + corner[3]) * 0.25;
          for (int i = 0; i < d.tetCount; ++i) {
            const auto& c = d.tets[i];
            // A Steiner child is (face piece area fraction) x (Steiner weight of the opposite
            // node): scale the centroid's 1/4 down to the smallest allowed weight.
            const double scale = d.usesSteiner ? std::min(1.0, steinerMargin / 0.25) : 1.0;
            worst = std::min(worst, scale * tetVolume(p[c[0]], p[c[1]], p[c[2]], p[c[3]]) / parent);
          }
        }
      } while (std::next_permutation(perm.begin(), perm.end()));
    }
  return worst;
}

}  // namespace blobvk::cutting
