#include "blobvk/cutting/topology.h"

#include "blobvk/cutting/prefault.h"
#include "blobvk/cutting/vec.h"

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
  // Headroom for the growth of a cutting session: without it the first cut events would copy
  // every per-tet and per-node array (O(n) per event until the doubling catches up).
  const std::size_t tetRoom = mesh_.tets.size() + mesh_.tets.size() / 2 + 4096;
  const std::size_t nodeRoom = mesh_.positions.size() + mesh_.positions.size() / 2 + 4096;
  mesh_.tets.reserve(tetRoom);
  mesh_.regions.reserve(tetRoom);
  alive_.reserve(tetRoom);
  mesh_.positions.reserve(nodeRoom);
  mesh_.restPositions.reserve(nodeRoom);
  prefaultCapacity(mesh_.tets);
  prefaultCapacity(mesh_.regions);
  prefaultCapacity(alive_);
  prefaultCapacity(mesh_.positions);
  prefaultCapacity(mesh_.restPositions);
  // Incidence runs sized to each node's degree plus room for the tets a few cuts add.
  std::vector<std::uint32_t> degree(mesh_.positions.size(), 0);
  for (const Tet& t : mesh_.tets)
    for (std::uint32_t n : t) {
      if (n >= mesh_.positions.size()) throw std::invalid_argument("CutTopology: tet node index out of range");
      ++degree[n];
    }
  for (auto& d : degree) d += 4;
  tetsOfNode_.layout(degree);
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

namespace {
bool holds(const Tet& t, std::uint32_t n) { return t[0] == n || t[1] == n || t[2] == n || t[3] == n; }
}  // namespace

bool CutTopology::hasEdge(std::uint32_t a, std::uint32_t b) const {
  if (a >= tetsOfNode_.nodeCount() || b >= tetsOfNode_.nodeCount()) return false;
  if (tetsOfNode_.of(b).size() < tetsOfNode_.of(a).size()) std::swap(a, b);
  for (std::uint32_t slot : tetsOfNode_.of(a))
    if (holds(mesh_.tets[slot], b)) return true;
  return false;
}

std::array<std::uint32_t, 2> CutTopology::tetsOfFace(std::uint32_t a, std::uint32_t b, std::uint32_t c) const {
  std::array<std::uint32_t, 2> found{kNone, kNone};
  const std::size_t nodes = tetsOfNode_.nodeCount();
  if (a >= nodes || b >= nodes || c >= nodes) return found;
  // Scan the shortest of the three lists.
  if (tetsOfNode_.of(b).size() < tetsOfNode_.of(a).size()) std::swap(a, b);
  if (tetsOfNode_.of(c).size() < tetsOfNode_.of(a).size()) std::swap(a, c);
  int count = 0;
  for (std::uint32_t slot : tetsOfNode_.of(a)) {
    const Tet& t = mesh_.tets[slot];
    if (holds(t, b) && holds(t, c)) {
      found[std::size_t(count++)] = slot;
      if (count == 2) break;
    }
  }
  return found;
}

void CutTopology::attach(std::uint32_t slot) {
  for (std::uint32_t n : mesh_.tets[slot]) tetsOfNode_.push(n, slot);
}

void CutTopology::detach(std::uint32_t slot) {
  for (std::uint32_t n : mesh_.tets[slot]) tetsOfNode_.remove(n, slot);
}

void CutTopology::retarget(std::uint32_t slot, const Tet& before, const Tet& after) {
  // Only the nodes that differ are touched: crack opening renumbers one or two nodes of a tet,
  // and a split's first child keeps some of its parent's nodes.
  auto repeats = [](const Tet& t) {
    return t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3];
  };
  if (repeats(before) || repeats(after)) {  // degenerate (a caller error selfCheck reports): by the book
    for (std::uint32_t n : before) tetsOfNode_.remove(n, slot);
    for (std::uint32_t n : after) tetsOfNode_.push(n, slot);
    return;
  }
  for (std::uint32_t n : before)
    if (!holds(after, n)) tetsOfNode_.remove(n, slot);
  for (std::uint32_t n : after)
    if (!holds(before, n)) tetsOfNode_.push(n, slot);
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
    // The incremental face query must see exactly the tets of the rebuild (two at most).
    const auto pair = tetsOfFace(key.a, key.b, key.c);
    const std::uint32_t known = (pair[0] != kNone) + (pair[1] != kNone);
    if (known != std::min<std::uint32_t>(use.count, 2)) ++report.incidenceMismatches;
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
      if (tetsOfFace(t[f[0]], t[f[1]], t[f[2]])[1] == kNone) out.boundaryFaces.push_back({t[f[0]], t[f[1]], t[f[2]]});
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
