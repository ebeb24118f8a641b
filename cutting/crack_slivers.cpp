#include "blobvk/cutting/crack_slivers.h"

#include "blobvk/cutting/vec.h"

#include <algorithm>

namespace blobvk::cutting {
namespace {

bool faceLess(const FaceKey& x, const FaceKey& y) {
  return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.c < y.c);
}

bool onCrack(const std::vector<FaceKey>& crack, const FaceKey& f) {
  return std::binary_search(crack.begin(), crack.end(), f, faceLess);
}

double squaredArea(const std::vector<mesh::Double3>& p, const FaceKey& f) {
  const mesh::Double3 u = p[f.b] - p[f.a], v = p[f.c] - p[f.a];
  const mesh::Double3 n{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
  return n.x * n.x + n.y * n.y + n.z * n.z;
}

}  // namespace

bool CrackSlivers::explore(const CutTopology& topology, const std::vector<FaceKey>& crack, std::span<const double> onCut,
                           std::uint32_t seed) {
  // A tet with a node off the cut surfaces ends the search: its piece is not a sliver.
  auto thin = [&](std::uint32_t slot) {
    for (std::uint32_t n : topology.tet(slot))
      if (!(n < onCut.size() && onCut[n] > 0)) return false;
    return true;
  };
  piece_.clear();
  piece_.push_back(seed);
  state_[seed] = 1;
  seen_.push_back(seed);
  bool small = thin(seed);
  for (std::size_t next = 0; next < piece_.size() && small; ++next) {
    const Tet& t = topology.tet(piece_[next]);
    for (const auto& lf : kTetFaces) {
      const FaceKey key = makeFaceKey(t[lf[0]], t[lf[1]], t[lf[2]]);
      const auto pair = topology.tetsOfFace(key.a, key.b, key.c);
      const std::uint32_t other = pair[0] == piece_[next] ? pair[1] : pair[0];
      if (other == kNone || onCrack(crack, key)) continue;
      if (state_[other] == 2) small = false;
      if (state_[other] != 0) continue;
      state_[other] = 1;
      seen_.push_back(other);
      piece_.push_back(other);
      if (piece_.size() > kMaxPieceTets || !thin(other)) small = false;
    }
  }
  if (!small)
    for (std::uint32_t slot : piece_) state_[slot] = 2;
  return small;
}

std::size_t CrackSlivers::attach(const CutTopology& topology, std::vector<FaceKey>& crack, std::span<const double> onCut) {
  if (state_.size() < topology.slotCount()) state_.resize(topology.slotCount() + topology.slotCount() / 2, 0);
  const auto& rest = topology.mesh().restPositions;
  uncrack_.clear();
  // Seeds in crack-face order (sorted keys): the result does not depend on hash or thread order.
  for (const FaceKey& face : crack)
    for (std::uint32_t seed : topology.tetsOfFace(face.a, face.b, face.c)) {
      if (seed == kNone || state_[seed] != 0 || !explore(topology, crack, onCut, seed)) continue;
      // One shared face attaches the piece to the tet behind it; the rest of the crack stays
      // open. The piece's crack face of largest area (ties: the smallest key) is the one.
      FaceKey best{kNone, kNone, kNone};
      double bestArea = -1;
      for (std::uint32_t slot : piece_) {
        const Tet& t = topology.tet(slot);
        for (const auto& lf : kTetFaces) {
          const FaceKey key = makeFaceKey(t[lf[0]], t[lf[1]], t[lf[2]]);
          if (!onCrack(crack, key)) continue;
          const double area = squaredArea(rest, key);
          if (area > bestArea || (area == bestArea && faceLess(key, best))) bestArea = area, best = key;
        }
      }
      if (bestArea >= 0) uncrack_.push_back(best);
    }
  for (std::uint32_t slot : seen_) state_[slot] = 0;
  seen_.clear();
  std::sort(uncrack_.begin(), uncrack_.end(), faceLess);
  uncrack_.erase(std::unique(uncrack_.begin(), uncrack_.end()), uncrack_.end());
  std::erase_if(crack, [&](const FaceKey& f) { return onCrack(uncrack_, f); });
  return uncrack_.size();
}

}  // namespace blobvk::cutting
