#include "blobvk/fem/boundary_faces.h"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <utility>

namespace blobvk::fem {
namespace {

using Face = BoundaryFaceSet::Face;

// Faces opposite each corner, oriented outward for a positively oriented tet (as findBoundaryFaces).
constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

// Explicit comparisons: std::array's == goes through memcmp, a call per comparison.
bool keyLess(const Face& a, const Face& b) {
  if (a[0] != b[0]) return a[0] < b[0];
  if (a[1] != b[1]) return a[1] < b[1];
  return a[2] < b[2];
}
bool sameKey(const Face& a, const Face& b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }

Face sortedKey(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
  return {a, b, c};
}

// Multiplicative hashing; the caller keeps the top bits, which every key bit reaches.
std::uint64_t hashKey(const Face& k) {
  return ((std::uint64_t(k[0]) * 0x9E3779B97F4A7C15ull + k[1]) * 0xC2B2AE3D27D4EB4Full + k[2]) * 0x165667B19E3779F9ull;
}

struct Users {
  int count = 0;
  Face oriented{};  // the face as its (last found) user orients it outward
};

// The tets using face `key`: the tets present in the incidence rows of all three of its nodes
// (rows are sorted by tet, so a three-way merge, without reading any tet). The corners the rows
// give say which corner is missing, hence the outward orientation.
Users countUsers(const Face& key, const NodeIncidence& incidence) {
  const std::uint32_t *a = incidence.begin(key[0]), *ea = incidence.end(key[0]);
  const std::uint32_t *b = incidence.begin(key[1]), *eb = incidence.end(key[1]);
  const std::uint32_t *c = incidence.begin(key[2]), *ec = incidence.end(key[2]);
  Users users;
  while (a != ea && b != eb && c != ec) {
    const std::uint32_t ta = NodeIncidence::tetOf(*a), tb = NodeIncidence::tetOf(*b), tc = NodeIncidence::tetOf(*c);
    if (ta == tb && tb == tc) {
      std::uint32_t nodeAt[4]{};
      const int ca = NodeIncidence::cornerOf(*a), cb = NodeIncidence::cornerOf(*b), cc = NodeIncidence::cornerOf(*c);
      nodeAt[ca] = key[0];
      nodeAt[cb] = key[1];
      nodeAt[cc] = key[2];
      const auto& f = kFaces[6 - ca - cb - cc];  // corners sum to 0 + 1 + 2 + 3
      users.oriented = {nodeAt[f[0]], nodeAt[f[1]], nodeAt[f[2]]};
      ++users.count;
      ++a, ++b, ++c;
      continue;
    }
    const std::uint32_t top = std::max({ta, tb, tc});
    if (ta < top) ++a;
    if (tb < top) ++b;
    if (tc < top) ++c;
  }
  return users;
}

}  // namespace

void BoundaryFaceSet::build(std::vector<Face>& faces) {
  std::vector<std::pair<Face, Face>> entries(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) entries[i] = {sortedKey(faces[i][0], faces[i][1], faces[i][2]), faces[i]};
  std::stable_sort(entries.begin(), entries.end(), [](const auto& x, const auto& y) { return keyLess(x.first, y.first); });
  const auto sameFace = [](const auto& x, const auto& y) { return sameKey(x.first, y.first); };
  entries.erase(std::unique(entries.begin(), entries.end(), sameFace), entries.end());
  // Spare room so that the in-place edits of later cuts rarely reallocate.
  const std::size_t room = entries.size() + entries.size() / 4 + 256;
  keys_.reserve(room);
  faces.reserve(room);
  keys_.resize(entries.size());
  faces.resize(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    keys_[i] = entries[i].first;
    faces[i] = entries[i].second;
  }
}

BoundaryFaceSet::KeyState& BoundaryFaceSet::state(const Face& key) {
  const std::size_t mask = table_.size() - 1;
  const int bits = std::countr_zero(table_.size());
  for (std::size_t slot = std::size_t(hashKey(key) >> (64 - bits));; slot = (slot + 1) & mask) {
    const std::uint32_t at = table_[slot];
    if (at == 0) {
      table_[slot] = std::uint32_t(states_.size() + 1);
      KeyState& s = states_.emplace_back();
      s.key = key;
      s.slot = std::uint32_t(slot);
      return s;
    }
    if (sameKey(states_[at - 1].key, key)) return states_[at - 1];
  }
}

void BoundaryFaceSet::clearStates() {
  for (const KeyState& s : states_) table_[s.slot] = 0;
  states_.clear();
}

void BoundaryFaceSet::update(const std::vector<Tet>& removed, const std::vector<Tet>& added, bool addedAreFinal,
                             std::uint32_t firstNewNode, const NodeIncidence& incidence, std::vector<Face>& faces) {
  // Table larger than the number of uses (so always with a free slot; ~40 % full, as most faces
  // of a change are used twice); it only grows, and is cleared entry by entry (O(change)).
  std::size_t size = 64;
  const std::size_t uses = 4 * (removed.size() + added.size());
  while (size <= uses) size *= 2;
  if (table_.size() < size) table_.assign(size, 0);
  states_.reserve(uses);
  for (const Tet& t : removed)
    for (const auto& f : kFaces) ++state(sortedKey(t[std::size_t(f[0])], t[std::size_t(f[1])], t[std::size_t(f[2])])).removedUses;
  for (const Tet& t : added)
    for (const auto& f : kFaces) {
      const Face oriented{t[std::size_t(f[0])], t[std::size_t(f[1])], t[std::size_t(f[2])]};
      KeyState& s = state(sortedKey(oriented[0], oriented[1], oriented[2]));
      ++s.addedUses;
      s.oriented = oriented;
    }
  edits_.clear();
  for (const KeyState& s : states_) {
    const bool hasNewNode = s.key[2] >= firstNewNode;  // keys are sorted: [2] is the largest node
    std::size_t at = keys_.size();
    if (!hasNewNode) at = std::size_t(std::lower_bound(keys_.begin(), keys_.end(), s.key, keyLess) - keys_.begin());
    const bool present = at < keys_.size() && sameKey(keys_[at], s.key);
    // Users before: 1 when listed; not listed, 0 for a face with a new node or one no removed
    // tet had, else 2 (a conforming mesh). Users after = before - removed + added.
    const int before = present ? 1 : (hasNewNode || s.removedUses == 0) ? 0 : 2;
    Users users{before - int(s.removedUses) + int(s.addedUses), s.oriented};
    // Re-count where that reasoning does not hold (slots written twice), where "no removed
    // tet had it" does not prove 0 users (a new face between old nodes) and where a face of
    // old nodes is to become boundary without an added user to orient it.
    const bool recount = !addedAreFinal ||
                         (!present && !hasNewNode && (s.removedUses == 0 || (users.count == 1 && s.addedUses == 0))) ||
                         users.count < 0 || users.count > 2;
    if (recount) users = countUsers(s.key, incidence);
    if (users.count == 1 && present)
      faces[at] = users.oriented;  // same key, maybe another user: no structural change
    else if (users.count == 1)
      edits_.push_back({s.key, users.oriented, true});
    else if (present)
      edits_.push_back({s.key, {}, false});
  }
  clearStates();
  applyEdits(faces);
}

// Edits in place, in two passes that only move the stretches between edits (memmove of runs,
// no per-face comparison): erases close their gaps front to back, then inserts open theirs back
// to front, so neither pass overwrites a face it has yet to move. Positions come from binary
// searches, each starting where the previous edit was found (edits are sorted). What is untouched
// is the list before the first edit; the moves cost a copy of the tail after it, no compare.
void BoundaryFaceSet::applyEdits(std::vector<Face>& faces) {
  if (edits_.empty()) return;
  std::sort(edits_.begin(), edits_.end(), [](const Edit& x, const Edit& y) { return keyLess(x.key, y.key); });
  // Erases: each listed face's position, then shift the runs between them left.
  positions_.clear();
  std::size_t from = 0;
  for (const Edit& e : edits_) {
    if (e.insert) continue;
    from = std::size_t(std::lower_bound(keys_.begin() + std::ptrdiff_t(from), keys_.end(), e.key, keyLess) - keys_.begin());
    if (from == keys_.size() || !sameKey(keys_[from], e.key))
      throw std::logic_error("boundary faces: erasing a face that is not listed");
    positions_.push_back(from++);
  }
  if (!positions_.empty()) {
    std::size_t out = positions_[0];
    for (std::size_t j = 0; j < positions_.size(); ++j) {
      const std::size_t runBegin = positions_[j] + 1;
      const std::size_t runEnd = j + 1 < positions_.size() ? positions_[j + 1] : keys_.size();
      std::copy(keys_.begin() + std::ptrdiff_t(runBegin), keys_.begin() + std::ptrdiff_t(runEnd), keys_.begin() + std::ptrdiff_t(out));
      std::copy(faces.begin() + std::ptrdiff_t(runBegin), faces.begin() + std::ptrdiff_t(runEnd), faces.begin() + std::ptrdiff_t(out));
      out += runEnd - runBegin;
    }
    keys_.resize(out);
    faces.resize(out);
  }
  // Inserts: positions in the list after the erases (no insert's key is listed), then shift
  // the runs right, last first, each insert landing in the gap in front of its run.
  positions_.clear();
  from = 0;
  for (const Edit& e : edits_) {
    if (!e.insert) continue;
    from = std::size_t(std::lower_bound(keys_.begin() + std::ptrdiff_t(from), keys_.end(), e.key, keyLess) - keys_.begin());
    positions_.push_back(from);
  }
  if (positions_.empty()) return;
  const std::size_t oldSize = keys_.size();
  keys_.resize(oldSize + positions_.size());
  faces.resize(oldSize + positions_.size());
  std::size_t runEnd = oldSize, insertIndex = positions_.size();
  for (std::size_t j = edits_.size(); j-- > 0;) {
    const Edit& e = edits_[j];
    if (!e.insert) continue;
    const std::size_t at = positions_[--insertIndex];
    const std::size_t shift = insertIndex + 1;  // inserts at or before this one
    std::copy_backward(keys_.begin() + std::ptrdiff_t(at), keys_.begin() + std::ptrdiff_t(runEnd), keys_.begin() + std::ptrdiff_t(runEnd + shift));
    std::copy_backward(faces.begin() + std::ptrdiff_t(at), faces.begin() + std::ptrdiff_t(runEnd), faces.begin() + std::ptrdiff_t(runEnd + shift));
    keys_[at + insertIndex] = e.key;
    faces[at + insertIndex] = e.oriented;
    runEnd = at;
  }
}

}  // namespace blobvk::fem
