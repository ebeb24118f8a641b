// Internal to surface_remesh.cpp: a closed, oriented triangle mesh that supports the local
// edits of isotropic remeshing (edge split, collapse, flip). Each directed edge maps to the one
// face that traverses it, so an edge's two faces and a vertex's ring are found without a
// half-edge structure. Faces and vertices are marked dead, never erased, until toTriMesh().
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace blobvk::mesh::remesh {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  friend bool operator==(const Vec3&, const Vec3&) = default;
};
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalized(const Vec3& a) {
  const double l = length(a);
  return l > 0 ? a * (1.0 / l) : Vec3{};
}

// Smallest interior angle (radians) of the triangle a, b, c; 0 when degenerate.
double minAngle(const Vec3& a, const Vec3& b, const Vec3& c);

inline constexpr std::uint32_t kNone = 0xffffffffu;
using Face = std::array<std::uint32_t, 3>;

// Directed edge (a << 32 | b) -> face: open addressing with linear probing and tombstones. The
// remesher looks edges up millions of times (every ring walk); std::unordered_map's node
// chasing made those lookups ~17 % of its time (measured with perf on the craniotomy).
class EdgeFaceMap {
 public:
  void reserve(std::size_t edges);
  std::uint32_t find(std::uint64_t key) const;  // kNone when absent
  bool insert(std::uint64_t key, std::uint32_t face);  // false when the key is present
  void erase(std::uint64_t key);

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0), kErased = kEmpty - 1;
  std::size_t slot(std::uint64_t key) const { return std::size_t((key * 0x9e3779b97f4a7c15ull) >> shift_); }
  void rehash(std::size_t size);  // size: a power of two

  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> faces_;
  std::size_t used_ = 0, live_ = 0;  // used_: live keys + tombstones
  int shift_ = 64;
};

class EditableMesh {
 public:
  explicit EditableMesh(const TriMesh& mesh);  // the mesh must be closed, manifold, oriented

  std::vector<Vec3> positions;

  std::size_t faceSlots() const { return faces_.size(); }
  bool faceAlive(std::uint32_t f) const { return faces_[f][0] != kNone; }
  const Face& face(std::uint32_t f) const { return faces_[f]; }
  bool vertexAlive(std::uint32_t v) const { return vertexFace_[v] != kNone; }
  Vec3 faceNormal(std::uint32_t f) const;  // unit; zero when degenerate

  // The face that traverses a -> b, or kNone.
  std::uint32_t faceOf(std::uint32_t a, std::uint32_t b) const;
  // The vertex of face f that is neither a nor b.
  std::uint32_t third(std::uint32_t f, std::uint32_t a, std::uint32_t b) const;
  // The neighbours of v and the faces around it, in ring order (cleared first).
  void ring(std::uint32_t v, std::vector<std::uint32_t>& neighbours, std::vector<std::uint32_t>& faces) const;

  // Splits edge a-b at p; returns the new vertex.
  std::uint32_t split(std::uint32_t a, std::uint32_t b, const Vec3& p);
  // Whether collapsing a-b keeps the surface a closed 2-manifold: a and b share exactly the two
  // opposite vertices (the link condition), and those keep a valence >= 4.
  bool collapseKeepsManifold(std::uint32_t a, std::uint32_t b) const;
  // Removes a; b moves to p and takes over a's faces.
  void collapse(std::uint32_t a, std::uint32_t b, const Vec3& p);
  // Whether flipping a-b keeps the surface a 2-manifold (the new edge does not exist yet, and
  // a and b keep a valence >= 4).
  bool flipKeepsManifold(std::uint32_t a, std::uint32_t b) const;
  // Replaces edge a-b by the edge between the two opposite vertices.
  void flip(std::uint32_t a, std::uint32_t b);

  TriMesh toTriMesh() const;  // live vertices renumbered in order, live faces in order

 private:
  static std::uint64_t key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }
  std::size_t valence(std::uint32_t v) const;
  void setFace(std::uint32_t f, const Face& vertices);  // f == faces_.size() appends
  void killFace(std::uint32_t f);

  std::vector<Face> faces_;
  std::vector<std::uint32_t> vertexFace_;  // one live face per vertex; kNone for a dead vertex
  EdgeFaceMap faceOfEdge_;
};

}  // namespace blobvk::mesh::remesh
