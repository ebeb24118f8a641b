// Internal to surface_remesh.cpp: keeps the remesher from folding a thin part of the surface
// into itself. A shell a few cells thick has its two sides closer than the target edge length;
// a collapse, flip or projection can then push a triangle through the other side, and TetGen
// rejects the result. Every edit is tested against the nearby faces (a spatial hash of face
// bounding boxes) and refused or undone where a triangle would cross one.
#pragma once

#include "blobvk/mesh/surface_remesh_topology.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::mesh::remesh {

using Triangle = std::array<Vec3, 3>;

// A triangle an edit would create: its vertex ids (to skip faces it shares an edge with) and
// where its corners would be.
struct PlannedFace {
  Face ids;
  Triangle corners;
};

// Whether two triangles share a point (touching counts; coplanar overlaps are not detected:
// an edit cannot make two faces of a closed surface coplanar and overlapping without also
// making some edge cross a face nearby).
bool trianglesIntersect(const Triangle& s, const Triangle& t);

// The same for two triangles with one common corner (index cornerS in s, cornerT in t): whether
// they share more than that point.
bool trianglesMeetBeyondCorner(const Triangle& s, int cornerS, const Triangle& t, int cornerT);

// Face ids listed in the cells their bounding boxes cover: a dense grid over the mesh's box
// (cells outside it are clamped to its border cells, which stays correct: inserts and queries
// clamp alike). Entries go stale when a face is edited or its vertices move; insert() adds the new
// cells, and queries test the faces' current geometry, so a stale entry costs time, never a wrong
// answer. rebuild() drops the stale ones and refits the grid to the mesh.
class FaceGrid {
 public:
  explicit FaceGrid(double cellSize) : wantedCell_(cellSize) {}

  void rebuild(const EditableMesh& mesh);
  void insert(const EditableMesh& mesh, std::uint32_t face);

  // A live face of `mesh` that `corners` (the triangle with vertex ids `ids`) crosses, sharing
  // at most one vertex with it and not in `ignore` (the faces an edit replaces); kNone if none.
  std::uint32_t crossedFace(const EditableMesh& mesh, const Face& ids, const Triangle& corners, std::span<const std::uint32_t> ignore);
  // The same for several triangles at once (one walk over the cells of their common box: the
  // faces around a collapsed edge lie close together).
  std::uint32_t crossedFace(const EditableMesh& mesh, std::span<const PlannedFace> planned, std::span<const std::uint32_t> ignore);

 private:
  struct Range {
    std::array<int, 3> lo, hi;
  };
  Range cells(const Vec3& lo, const Vec3& hi) const;
  std::size_t index(int x, int y, int z) const { return (std::size_t(z) * std::size_t(dims_[1]) + std::size_t(y)) * std::size_t(dims_[0]) + std::size_t(x); }

  double wantedCell_, cell_ = 1;
  Vec3 origin_;
  std::array<int, 3> dims_{0, 0, 0};
  // A face and its bounding box when it was inserted: most entries a query meets are rejected on
  // the box alone, without touching the mesh (measured: the entry walk was ~30 % of the clean-up).
  struct Entry {
    std::uint32_t face;
    float lo[3], hi[3];  // rounded outwards
  };
  std::vector<std::vector<Entry>> faces_;  // per cell
  std::vector<std::uint32_t> seen_;  // per face: the query stamp that last tested it
  std::uint32_t stamp_ = 0;
};

}  // namespace blobvk::mesh::remesh
