#include "fem/boundary_faces.h"

#include <algorithm>

namespace blobvk::fem {
namespace {

// Faces opposite each corner, oriented outward for a positively oriented tet (as findBoundaryFaces).
constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

BoundaryFaceSet::Face sortedKey(BoundaryFaceSet::Face f) {
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace

void BoundaryFaceSet::build(const std::vector<Face>& faces) {
  faces_.clear();
  for (const Face& f : faces) faces_.emplace(sortedKey(f), f);
}

void BoundaryFaceSet::collectFaces(const std::array<std::uint32_t, 4>& t, std::vector<Face>& keys) {
  for (const auto& f : kFaces) keys.push_back(sortedKey({t[std::size_t(f[0])], t[std::size_t(f[1])], t[std::size_t(f[2])]}));
}

void BoundaryFaceSet::update(std::vector<Face> removed, std::vector<Face> added,
                             const std::vector<std::array<std::uint32_t, 4>>& tets, const NodeIncidence& incidence) {
  std::sort(added.begin(), added.end());
  std::vector<Face> keys = std::move(removed);
  for (std::size_t i = 0; i < added.size();) {
    std::size_t j = i + 1;
    while (j < added.size() && added[j] == added[i]) ++j;
    if (j - i >= 2)
      faces_.erase(added[i]);  // two new tets share it: interior (a face has at most two tets)
    else
      keys.push_back(added[i]);
    i = j;
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  for (const Face& key : keys) {
    int users = 0;
    Face oriented{};
    std::uint32_t scan = key[0];  // the shortest of the three incidence rows
    for (std::uint32_t v : key)
      if (incidence.count(v) < incidence.count(scan)) scan = v;
    for (const std::uint32_t* p = incidence.begin(scan); p != incidence.end(scan); ++p) {
      const auto& t = tets[NodeIncidence::tetOf(*p)];
      int missing = -1, found = 0;
      for (int k = 0; k < 4; ++k) {
        if (t[std::size_t(k)] == key[0] || t[std::size_t(k)] == key[1] || t[std::size_t(k)] == key[2])
          ++found;
        else
          missing = k;
      }
      if (found != 3) continue;
      ++users;
      const auto& f = kFaces[missing];
      oriented = {t[std::size_t(f[0])], t[std::size_t(f[1])], t[std::size_t(f[2])]};
    }
    const auto at = faces_.lower_bound(key);
    const bool present = at != faces_.end() && at->first == key;
    if (users == 1 && present)
      at->second = oriented;
    else if (users == 1)
      faces_.emplace_hint(at, key, oriented);
    else if (present)
      faces_.erase(at);
  }
}

std::vector<BoundaryFaceSet::Face> BoundaryFaceSet::faces() const {
  std::vector<Face> out;
  out.reserve(faces_.size());
  for (const auto& [key, face] : faces_) out.push_back(face);
  return out;
}

}  // namespace blobvk::fem
