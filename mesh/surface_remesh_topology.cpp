#include "blobvk/mesh/surface_remesh_topology.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <numbers>
#include <stdexcept>

namespace blobvk::mesh::remesh {

double minAngle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 corners[3] = {a, b, c};
  double best = std::numbers::pi;
  for (int i = 0; i < 3; ++i) {
    const Vec3 u = corners[(i + 1) % 3] - corners[i], v = corners[(i + 2) % 3] - corners[i];
    const double lu = length(u), lv = length(v);
    if (!(lu > 0 && lv > 0)) return 0;
    // atan2 of |u x v| and u.v: accurate for the tiny angles this code exists to remove.
    best = std::min(best, std::atan2(length(cross(u, v)), dot(u, v)));
  }
  return best;
}

void EdgeFaceMap::reserve(std::size_t edges) {
  if (2 * edges > keys_.size()) rehash(std::bit_ceil(std::max<std::size_t>(16, 2 * edges)));
}

void EdgeFaceMap::rehash(std::size_t size) {
  std::vector<std::uint64_t> oldKeys(size, kEmpty);
  std::vector<std::uint32_t> oldFaces(size, kNone);
  oldKeys.swap(keys_);
  oldFaces.swap(faces_);
  shift_ = 64 - std::countr_zero(size);
  used_ = live_ = 0;
  for (std::size_t i = 0; i < oldKeys.size(); ++i)
    if (oldKeys[i] != kEmpty && oldKeys[i] != kErased) insert(oldKeys[i], oldFaces[i]);
}

std::uint32_t EdgeFaceMap::find(std::uint64_t key) const {
  if (keys_.empty()) return kNone;
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t i = slot(key);; i = (i + 1) & mask) {
    if (keys_[i] == key) return faces_[i];
    if (keys_[i] == kEmpty) return kNone;
  }
}

bool EdgeFaceMap::insert(std::uint64_t key, std::uint32_t face) {
  // At most half the slots used (live keys and tombstones), so probes stay short and end.
  if (2 * (used_ + 1) > keys_.size()) rehash(std::bit_ceil(std::max<std::size_t>(16, 4 * (live_ + 1))));
  const std::size_t mask = keys_.size() - 1;
  std::size_t tombstone = SIZE_MAX;
  for (std::size_t i = slot(key);; i = (i + 1) & mask) {
    if (keys_[i] == key) return false;
    if (keys_[i] == kErased && tombstone == SIZE_MAX) tombstone = i;
    if (keys_[i] == kEmpty) {
      const std::size_t at = tombstone == SIZE_MAX ? i : tombstone;
      if (at == i) ++used_;
      keys_[at] = key;
      faces_[at] = face;
      ++live_;
      return true;
    }
  }
}

void EdgeFaceMap::erase(std::uint64_t key) {
  if (keys_.empty()) return;
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t i = slot(key);; i = (i + 1) & mask) {
    if (keys_[i] == key) {
      keys_[i] = kErased;  // a tombstone: still counted in used_ until the next rehash
      --live_;
      return;
    }
    if (keys_[i] == kEmpty) return;
  }
}

EditableMesh::EditableMesh(const TriMesh& mesh) {
  positions.reserve(mesh.positions.size());
  for (const Float3& p : mesh.positions) positions.push_back({p.x, p.y, p.z});
  vertexFace_.assign(mesh.positions.size(), kNone);
  faces_.reserve(mesh.triangles.size());
  faceOfEdge_.reserve(mesh.triangles.size() * 4);
  for (const auto& t : mesh.triangles) setFace(std::uint32_t(faces_.size()), t);
}

Vec3 EditableMesh::faceNormal(std::uint32_t f) const {
  const Face& t = faces_[f];
  return normalized(cross(positions[t[1]] - positions[t[0]], positions[t[2]] - positions[t[0]]));
}

std::uint32_t EditableMesh::faceOf(std::uint32_t a, std::uint32_t b) const {
  return faceOfEdge_.find(key(a, b));
}

std::uint32_t EditableMesh::third(std::uint32_t f, std::uint32_t a, std::uint32_t b) const {
  for (std::uint32_t v : faces_[f])
    if (v != a && v != b) return v;
  return kNone;
}

void EditableMesh::ring(std::uint32_t v, std::vector<std::uint32_t>& neighbours, std::vector<std::uint32_t>& faces) const {
  neighbours.clear();
  faces.clear();
  const std::uint32_t first = vertexFace_[v];
  std::uint32_t f = first;
  do {
    const Face& t = faces_[f];
    const int i = t[0] == v ? 0 : t[1] == v ? 1 : 2;
    neighbours.push_back(t[std::size_t((i + 1) % 3)]);
    faces.push_back(f);
    // Face f traverses x -> v; the next face around v traverses v -> x.
    f = faceOf(v, t[std::size_t((i + 2) % 3)]);
    if (f == kNone || faces.size() > faces_.size()) throw std::logic_error("remeshSurface: broken vertex ring");
  } while (f != first);
}

std::size_t EditableMesh::valence(std::uint32_t v) const {
  std::vector<std::uint32_t> neighbours, faces;
  ring(v, neighbours, faces);
  return neighbours.size();
}

void EditableMesh::setFace(std::uint32_t f, const Face& vertices) {
  if (f == faces_.size()) faces_.push_back({kNone, kNone, kNone});
  if (faceAlive(f)) killFace(f);
  faces_[f] = vertices;
  for (int k = 0; k < 3; ++k) {
    if (!faceOfEdge_.insert(key(vertices[std::size_t(k)], vertices[std::size_t((k + 1) % 3)]), f)) throw std::logic_error("remeshSurface: an edit would make an edge non-manifold");
    vertexFace_[vertices[std::size_t(k)]] = f;
  }
}

void EditableMesh::killFace(std::uint32_t f) {
  const Face& t = faces_[f];
  for (int k = 0; k < 3; ++k) faceOfEdge_.erase(key(t[std::size_t(k)], t[std::size_t((k + 1) % 3)]));
  faces_[f] = {kNone, kNone, kNone};
}

std::uint32_t EditableMesh::split(std::uint32_t a, std::uint32_t b, const Vec3& p) {
  const std::uint32_t f = faceOf(a, b), e = faceOf(b, a);
  const std::uint32_t c = third(f, a, b), d = third(e, b, a);
  const auto m = std::uint32_t(positions.size());
  positions.push_back(p);
  vertexFace_.push_back(kNone);
  setFace(f, {a, m, c});
  setFace(std::uint32_t(faces_.size()), {m, b, c});
  setFace(e, {b, m, d});
  setFace(std::uint32_t(faces_.size()), {m, a, d});
  return m;
}

bool EditableMesh::collapseKeepsManifold(std::uint32_t a, std::uint32_t b) const {
  const std::uint32_t f = faceOf(a, b), e = faceOf(b, a);
  const std::uint32_t c = third(f, a, b), d = third(e, b, a);
  if (c == d) return false;
  std::vector<std::uint32_t> ringA, ringB, faces;
  ring(a, ringA, faces);
  ring(b, ringB, faces);
  std::size_t shared = 0;
  for (std::uint32_t x : ringA)
    if (std::find(ringB.begin(), ringB.end(), x) != ringB.end()) ++shared;
  return shared == 2 && valence(c) >= 4 && valence(d) >= 4;
}

void EditableMesh::collapse(std::uint32_t a, std::uint32_t b, const Vec3& p) {
  std::vector<std::uint32_t> neighbours, faces;
  ring(a, neighbours, faces);
  const std::uint32_t f = faceOf(a, b), e = faceOf(b, a);
  killFace(f);
  killFace(e);
  for (std::uint32_t g : faces) {
    if (g == f || g == e) continue;
    Face t = faces_[g];
    for (std::uint32_t& v : t)
      if (v == a) v = b;
    setFace(g, t);
  }
  positions[b] = p;
  vertexFace_[a] = kNone;
}

bool EditableMesh::flipKeepsManifold(std::uint32_t a, std::uint32_t b) const {
  const std::uint32_t c = third(faceOf(a, b), a, b), d = third(faceOf(b, a), b, a);
  return c != d && faceOf(c, d) == kNone && faceOf(d, c) == kNone && valence(a) >= 4 && valence(b) >= 4;
}

void EditableMesh::flip(std::uint32_t a, std::uint32_t b) {
  const std::uint32_t f = faceOf(a, b), e = faceOf(b, a);
  const std::uint32_t c = third(f, a, b), d = third(e, b, a);
  // Both faces go first: each new face reuses a directed edge of the other old one.
  killFace(f);
  killFace(e);
  setFace(f, {c, a, d});
  setFace(e, {d, b, c});
}

TriMesh EditableMesh::toTriMesh() const {
  TriMesh out;
  std::vector<std::uint32_t> index(positions.size(), kNone);
  for (std::uint32_t v = 0; v < positions.size(); ++v) {
    if (!vertexAlive(v)) continue;
    index[v] = std::uint32_t(out.positions.size());
    out.positions.push_back({float(positions[v].x), float(positions[v].y), float(positions[v].z)});
  }
  for (std::uint32_t f = 0; f < faces_.size(); ++f)
    if (faceAlive(f)) out.triangles.push_back({index[faces_[f][0]], index[faces_[f][1]], index[faces_[f][2]]});
  return out;
}

}  // namespace blobvk::mesh::remesh
