#include "cutting/topology.h"

#include "cutting/vec.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace blobvk::cutting {

FaceKey makeFaceKey(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
  return {a, b, c};
}

std::string SelfCheckReport::summary() const {
  std::ostringstream s;
  s << "tets " << tets << ", nodes " << nodes << ", interior faces " << interiorFaces << ", boundary faces "
    << boundaryFaces << ", over-shared " << overSharedFaces << ", misoriented " << misorientedFaces
    << ", duplicate " << duplicateTets << ", non-positive " << nonPositiveTets << ", degenerate " << degenerateTets
    << ", incidence mismatches " << incidenceMismatches << (ok() ? " (ok)" : " (FAILED)");
  return s.str();
}

CutTopology::CutTopology(mesh::TetMesh mesh) : mesh_(std::move(mesh)) {
  if (mesh_.restPositions.size() != mesh_.positions.size())
    throw std::invalid_argument("CutTopology: restPositions and positions differ in size");
  if (!mesh_.regions.empty() && mesh_.regions.size() != mesh_.tets.size())
    throw std::invalid_argument("CutTopology: regions must be empty or one per tet");
  if (mesh_.regions.empty()) mesh_.regions.assign(mesh_.tets.size(), 0);
  alive_.assign(mesh_.tets.size(), 1);
  // Incidence runs sized to each node's degree plus room for the tets a few cuts add.
  std::vector<std::uint32_t> degree(mesh_.positions.size(), 0);
  for (const Tet& t : mesh_.tets)
    for (std::uint32_t n : t) {
      if (n >= mesh_.positions.size()) throw std::invalid_argument("CutTopology: tet node index out of range");
      ++degree[n];
    }
  for (auto& d : degree) d += 4;
  tetsOfNode_.layout(degree);
  // Euler: about 1.2 edges and 2 faces per tet in a solid mesh; room for the growth of cutting.
  edges_.reserve(mesh_.tets.size() * 2);
  faces_.reserve(mesh_.tets.size() * 3);
  for (std::uint32_t t = 0; t < mesh_.tets.size(); ++t) attach(t);
}

std::uint32_t CutTopology::addNode(mesh::Double3 position, mesh::Double3 rest) {
  mesh_.positions.push_back(position);
  mesh_.restPositions.push_back(rest);
  tetsOfNode_.addNode();
  return std::uint32_t(mesh_.positions.size() - 1);
}

std::uint32_t CutTopology::addTet(const Tet& nodes, std::uint32_t region) {
  std::uint32_t slot;
  if (!freeSlots_.empty()) {
    slot = freeSlots_.back();
    freeSlots_.pop_back();
    mesh_.tets[slot] = nodes;
    mesh_.regions[slot] = region;
  } else {
    slot = std::uint32_t(mesh_.tets.size());
    mesh_.tets.push_back(nodes);
    mesh_.regions.push_back(region);
    alive_.push_back(0);
  }
  alive_[slot] = 1;
  attach(slot);
  return slot;
}

void CutTopology::setTet(std::uint32_t slot, const Tet& nodes) {
  if (!alive(slot)) throw std::logic_error("CutTopology::setTet on a dead slot");
  const Tet before = mesh_.tets[slot];
  mesh_.tets[slot] = nodes;
  retarget(slot, before, nodes);
}

void CutTopology::removeTet(std::uint32_t slot) {
  if (!alive(slot)) throw std::logic_error("CutTopology::removeTet on a dead slot");
  detach(slot);
  alive_[slot] = 0;
  freeSlots_.push_back(slot);
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> CutTopology::compact() {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> moves;
  std::sort(freeSlots_.begin(), freeSlots_.end());
  std::size_t end = mesh_.tets.size();
  for (std::uint32_t hole : freeSlots_) {
    while (end > 0 && !alive_[end - 1]) --end;
    if (hole >= end) break;
    const std::uint32_t from = std::uint32_t(end - 1);
    const Tet nodes = mesh_.tets[from];
    const std::uint32_t region = mesh_.regions[from];
    detach(from);
    alive_[from] = 0;
    mesh_.tets[hole] = nodes;
    mesh_.regions[hole] = region;
    alive_[hole] = 1;
    attach(hole);
    moves.emplace_back(from, hole);
    --end;
  }
  while (end > 0 && !alive_[end - 1]) --end;
  mesh_.tets.resize(end);
  mesh_.regions.resize(end);
  alive_.resize(end);
  freeSlots_.clear();
  return moves;
}

std::array<std::uint32_t, 2> CutTopology::tetsOfFace(std::uint32_t a, std::uint32_t b, std::uint32_t c) const {
  const FaceRecord* r = faces_.find(makeFaceKey(a, b, c));
  if (r == nullptr) return {kNone, kNone};
  return {r->tets[0], r->tets[1]};
}

void CutTopology::addFaceUse(const FaceKey& key, std::uint32_t slot) {
  FaceRecord& r = faces_[key];
  if (r.tets[0] == kNone) r.tets[0] = slot;
  else if (r.tets[1] == kNone) r.tets[1] = slot;
  else ++r.extra;
}

void CutTopology::removeFaceUse(const FaceKey& key, std::uint32_t slot) {
  FaceRecord* record = faces_.find(key);
  if (record == nullptr) return;
  FaceRecord& r = *record;
  // Beyond two tets (a conformity error) the record only counts; selfCheck reports it.
  if (r.tets[0] == slot) {
    r.tets[0] = r.tets[1];
    r.tets[1] = kNone;
  } else if (r.tets[1] == slot) {
    r.tets[1] = kNone;
  } else if (r.extra > 0) {
    --r.extra;
  }
  if (r.tets[0] == kNone && r.extra == 0) faces_.erase(key);
}

void CutTopology::removeEdgeUse(std::uint64_t key) {
  std::uint32_t* count = edges_.find(key);
  if (count != nullptr && --*count == 0) edges_.erase(key);
}

// The edge and face keys of a tet, with their table slots prefetched: attach and detach then
// touch all ten entries without waiting on each miss in turn.
CutTopology::TetKeys CutTopology::prefetchKeys(const Tet& t) const {
  TetKeys keys;
  for (int e = 0; e < 6; ++e) edges_.prefetch(keys.edges[e] = edgeKey(t[kTetEdges[e][0]], t[kTetEdges[e][1]]));
  for (int f = 0; f < 4; ++f)
    faces_.prefetch(keys.faces[f] = makeFaceKey(t[kTetFaces[f][0]], t[kTetFaces[f][1]], t[kTetFaces[f][2]]));
  return keys;
}

void CutTopology::attach(std::uint32_t slot) {
  const Tet& t = mesh_.tets[slot];
  const TetKeys keys = prefetchKeys(t);
  for (std::uint32_t n : t) tetsOfNode_.push(n, slot);
  for (std::uint64_t k : keys.edges) ++edges_[k];
  for (const FaceKey& k : keys.faces) addFaceUse(k, slot);
}

void CutTopology::detach(std::uint32_t slot) {
  const Tet& t = mesh_.tets[slot];
  const TetKeys keys = prefetchKeys(t);
  for (std::uint32_t n : t) tetsOfNode_.remove(n, slot);
  for (std::uint64_t k : keys.edges) removeEdgeUse(k);
  for (const FaceKey& k : keys.faces) removeFaceUse(k, slot);
}

void CutTopology::retarget(std::uint32_t slot, const Tet& before, const Tet& after) {
  // Only the incidences that differ are touched: crack opening renumbers one or two nodes of a
  // tet, which leaves one face and three edges in place, and a split's first child often keeps
  // a face of its parent.
  auto contains = [](const Tet& t, std::uint32_t n) { return t[0] == n || t[1] == n || t[2] == n || t[3] == n; };
  auto repeats = [](const Tet& t) {
    return t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3];
  };
  if (repeats(before) || repeats(after)) {  // degenerate (a caller error selfCheck reports): by the book
    mesh_.tets[slot] = before;
    detach(slot);
    mesh_.tets[slot] = after;
    attach(slot);
    return;
  }
  std::array<std::uint64_t, 6> oldEdges{}, newEdges{};
  for (int e = 0; e < 6; ++e) {
    edges_.prefetch(oldEdges[e] = edgeKey(before[kTetEdges[e][0]], before[kTetEdges[e][1]]));
    edges_.prefetch(newEdges[e] = edgeKey(after[kTetEdges[e][0]], after[kTetEdges[e][1]]));
  }
  std::array<FaceKey, 4> oldFaces{}, newFaces{};
  for (int f = 0; f < 4; ++f) {
    faces_.prefetch(oldFaces[f] = makeFaceKey(before[kTetFaces[f][0]], before[kTetFaces[f][1]], before[kTetFaces[f][2]]));
    faces_.prefetch(newFaces[f] = makeFaceKey(after[kTetFaces[f][0]], after[kTetFaces[f][1]], after[kTetFaces[f][2]]));
  }
  for (std::uint32_t n : before)
    if (!contains(after, n)) tetsOfNode_.remove(n, slot);
  for (std::uint32_t n : after)
    if (!contains(before, n)) tetsOfNode_.push(n, slot);
  for (std::uint64_t k : oldEdges)
    if (std::find(newEdges.begin(), newEdges.end(), k) == newEdges.end()) removeEdgeUse(k);
  for (std::uint64_t k : newEdges)
    if (std::find(oldEdges.begin(), oldEdges.end(), k) == oldEdges.end()) ++edges_[k];
  for (const FaceKey& k : oldFaces)
    if (std::find(newFaces.begin(), newFaces.end(), k) == newFaces.end()) removeFaceUse(k, slot);
  for (const FaceKey& k : newFaces)
    if (std::find(oldFaces.begin(), oldFaces.end(), k) == oldFaces.end()) addFaceUse(k, slot);
}

SelfCheckReport CutTopology::selfCheck() const {
  SelfCheckReport report;
  report.nodes = mesh_.positions.size();
  struct Use {
    std::uint32_t count = 0;
    std::uint32_t tet[2] = {kNone, kNone};
    Face oriented[2];
  };
  std::unordered_map<FaceKey, Use, FaceKeyHash> faces;
  faces.reserve(liveTetCount() * 3);
  struct TetKeyHash {
    std::size_t operator()(const Tet& t) const {
      return FaceKeyHash{}(FaceKey{t[0], t[1], t[2]}) ^ (std::size_t(t[3]) * 0x9E3779B97F4A7C15ull);
    }
  };
  std::unordered_map<Tet, std::uint32_t, TetKeyHash> tetSet;
  std::size_t incidenceEntries = 0;
  for (std::uint32_t s = 0; s < mesh_.tets.size(); ++s) {
    if (!alive_[s]) continue;
    ++report.tets;
    const Tet& t = mesh_.tets[s];
    bool bad = false;
    for (int i = 0; i < 4; ++i) {
      if (t[i] >= report.nodes) bad = true;
      for (int j = i + 1; j < 4; ++j)
        if (t[i] == t[j]) bad = true;
    }
    if (bad) {
      ++report.degenerateTets;
      continue;
    }
    const auto& r = mesh_.restPositions;
    if (!(tetVolume(r[t[0]], r[t[1]], r[t[2]], r[t[3]]) > 0.0)) ++report.nonPositiveTets;
    Tet sorted = t;
    std::sort(sorted.begin(), sorted.end());
    if (++tetSet[sorted] > 1) ++report.duplicateTets;
    for (std::uint32_t n : t) {
      const auto list = tetsOfNode_.of(n);
      if (std::find(list.begin(), list.end(), s) == list.end()) ++report.incidenceMismatches;
    }
    incidenceEntries += 4;
    for (const auto& f : kTetFaces) {
      Use& use = faces[makeFaceKey(t[f[0]], t[f[1]], t[f[2]])];
      if (use.count < 2) {
        use.tet[use.count] = s;
        use.oriented[use.count] = {t[f[0]], t[f[1]], t[f[2]]};
      }
      ++use.count;
    }
  }
  std::size_t listed = 0;
  for (std::uint32_t n = 0; n < tetsOfNode_.nodeCount(); ++n) listed += tetsOfNode_.of(n).size();
  if (listed != incidenceEntries || listed != tetsOfNode_.totalEntries()) ++report.incidenceMismatches;
  if (faces.size() != faces_.size()) ++report.incidenceMismatches;
  for (const auto& [key, use] : faces) {
    if (use.count == 1) ++report.boundaryFaces;
    else if (use.count == 2) ++report.interiorFaces;
    else ++report.overSharedFaces;
    if (use.count == 2) {
      // Opposite traversal: rotating the second face so it starts with the first face's first
      // node, its order must be the reverse.
      const Face& f0 = use.oriented[0];
      Face f1 = use.oriented[1];
      while (f1[0] != f0[0]) std::rotate(f1.begin(), f1.begin() + 1, f1.end());
      if (!(f1[1] == f0[2] && f1[2] == f0[1])) ++report.misorientedFaces;
    }
    const FaceRecord* record = faces_.find(key);
    if (record == nullptr) {
      ++report.incidenceMismatches;
      continue;
    }
    const std::uint32_t known = (record->tets[0] != kNone) + (record->tets[1] != kNone) + record->extra;
    if (known != use.count) ++report.incidenceMismatches;
  }
  return report;
}

mesh::TetMesh CutTopology::toTetMesh() const {
  mesh::TetMesh out;
  out.positions = mesh_.positions;
  out.restPositions = mesh_.restPositions;
  for (std::uint32_t s = 0; s < mesh_.tets.size(); ++s) {
    if (!alive_[s]) continue;
    out.tets.push_back(mesh_.tets[s]);
    out.regions.push_back(mesh_.regions[s]);
  }
  for (const auto& t : out.tets)
    for (const auto& f : kTetFaces) {
      const FaceRecord* r = faces_.find(makeFaceKey(t[f[0]], t[f[1]], t[f[2]]));
      if (r != nullptr && r->tets[1] == kNone && r->extra == 0)
        out.boundaryFaces.push_back({t[f[0]], t[f[1]], t[f[2]]});
    }
  return out;
}

double CutTopology::totalRestVolume() const {
  double sum = 0.0;
  const auto& r = mesh_.restPositions;
  for (std::uint32_t s = 0; s < mesh_.tets.size(); ++s)
    if (alive_[s]) {
      const Tet& t = mesh_.tets[s];
      sum += tetVolume(r[t[0]], r[t[1]], r[t[2]], r[t[3]]);
    }
  return sum;
}

}  // namespace blobvk::cutting
