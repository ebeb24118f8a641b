#include "blobvk/mesh/surface_remesh_intersections.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace blobvk::mesh::remesh {
namespace {

// Whether segment p-q meets triangle abc (boundary included); false for a segment in its plane.
bool segmentMeetsTriangle(const Vec3& p, const Vec3& q, const Triangle& t) {
  const Vec3 n = cross(t[1] - t[0], t[2] - t[0]);
  const double dp = dot(p - t[0], n), dq = dot(q - t[0], n);
  if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0) || dp == dq) return false;
  const Vec3 x = p + (q - p) * (dp / (dp - dq));
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = t[std::size_t(k)];
    const Vec3& b = t[std::size_t((k + 1) % 3)];
    if (dot(cross(b - a, x - a), n) < 0) return false;
  }
  return true;
}

void boundingBox(const Triangle& t, Vec3& lo, Vec3& hi) {
  lo = {std::min({t[0].x, t[1].x, t[2].x}), std::min({t[0].y, t[1].y, t[2].y}), std::min({t[0].z, t[1].z, t[2].z})};
  hi = {std::max({t[0].x, t[1].x, t[2].x}), std::max({t[0].y, t[1].y, t[2].y}), std::max({t[0].z, t[1].z, t[2].z})};
}

// Whether the bounding boxes of s and t overlap: rejects most grid neighbours before the
// segment tests.
bool boxesOverlap(const Triangle& s, const Triangle& t) {
  const auto apart = [&](auto axis) {
    return std::max({axis(s[0]), axis(s[1]), axis(s[2])}) < std::min({axis(t[0]), axis(t[1]), axis(t[2])}) ||
           std::max({axis(t[0]), axis(t[1]), axis(t[2])}) < std::min({axis(s[0]), axis(s[1]), axis(s[2])});
  };
  return !apart([](const Vec3& p) { return p.x; }) && !apart([](const Vec3& p) { return p.y; }) && !apart([](const Vec3& p) { return p.z; });
}

Triangle corners(const EditableMesh& mesh, std::uint32_t f) {
  const Face& t = mesh.face(f);
  return {mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
}

}  // namespace

bool trianglesMeetBeyondCorner(const Triangle& s, int cornerS, const Triangle& t, int cornerT) {
  // Two non-coplanar triangles through a common corner meet in a segment from it; its other
  // end lies on an edge, and not on one through the corner unless that edge lies in the other
  // triangle's plane: testing the two edges opposite the corner finds it.
  const auto opposite = [](const Triangle& x, int k, const Triangle& y) {
    return segmentMeetsTriangle(x[std::size_t((k + 1) % 3)], x[std::size_t((k + 2) % 3)], y);
  };
  return opposite(s, cornerS, t) || opposite(t, cornerT, s);
}

bool trianglesIntersect(const Triangle& s, const Triangle& t) {
  for (int k = 0; k < 3; ++k) {
    if (segmentMeetsTriangle(s[std::size_t(k)], s[std::size_t((k + 1) % 3)], t)) return true;
    if (segmentMeetsTriangle(t[std::size_t(k)], t[std::size_t((k + 1) % 3)], s)) return true;
  }
  return false;
}

FaceGrid::Range FaceGrid::cells(const Vec3& lo, const Vec3& hi) const {
  Range r;
  const double l[3] = {lo.x - origin_.x, lo.y - origin_.y, lo.z - origin_.z};
  const double h[3] = {hi.x - origin_.x, hi.y - origin_.y, hi.z - origin_.z};
  for (std::size_t a = 0; a < 3; ++a) {
    const auto clamp = [&](double v) { return int(std::clamp(std::floor(v / cell_), 0.0, double(dims_[a] - 1))); };
    r.lo[a] = clamp(l[a]);
    r.hi[a] = clamp(h[a]);
  }
  return r;
}

void FaceGrid::rebuild(const EditableMesh& mesh) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) {
    if (!mesh.vertexAlive(v)) continue;
    const Vec3& p = mesh.positions[v];
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  // At most 2^21 cells (a target edge tiny next to the model would otherwise ask for billions):
  // bigger cells only mean longer lists.
  const double extent[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
  cell_ = wantedCell_;
  while ((extent[0] / cell_ + 1) * (extent[1] / cell_ + 1) * (extent[2] / cell_ + 1) > double(1 << 21)) cell_ *= 2;
  origin_ = lo;
  for (std::size_t a = 0; a < 3; ++a) dims_[a] = std::max(1, int(extent[a] / cell_) + 1);
  const std::size_t count = std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]);
  if (faces_.size() != count) faces_.assign(count, {});
  for (auto& list : faces_) list.clear();
  for (std::uint32_t f = 0; f < mesh.faceSlots(); ++f)
    if (mesh.faceAlive(f)) insert(mesh, f);
}

void FaceGrid::insert(const EditableMesh& mesh, std::uint32_t face) {
  if (faces_.empty()) return rebuild(mesh);
  Vec3 lo, hi;
  boundingBox(corners(mesh, face), lo, hi);
  const auto down = [](double v) { return std::nextafter(float(v), -std::numeric_limits<float>::infinity()); };
  const auto up = [](double v) { return std::nextafter(float(v), std::numeric_limits<float>::infinity()); };
  const Entry entry{face, {down(lo.x), down(lo.y), down(lo.z)}, {up(hi.x), up(hi.y), up(hi.z)}};
  const Range r = cells(lo, hi);
  for (int z = r.lo[2]; z <= r.hi[2]; ++z)
    for (int y = r.lo[1]; y <= r.hi[1]; ++y)
      for (int x = r.lo[0]; x <= r.hi[0]; ++x) faces_[index(x, y, z)].push_back(entry);
}

std::uint32_t FaceGrid::crossedFace(const EditableMesh& mesh, const Face& ids, const Triangle& t, std::span<const std::uint32_t> ignore) {
  const PlannedFace one[1] = {{ids, t}};
  return crossedFace(mesh, one, ignore);
}

std::uint32_t FaceGrid::crossedFace(const EditableMesh& mesh, std::span<const PlannedFace> planned, std::span<const std::uint32_t> ignore) {
  if (planned.empty()) return kNone;
  if (seen_.size() < mesh.faceSlots()) seen_.resize(mesh.faceSlots(), 0);
  if (++stamp_ == 0) {  // wrapped: forget every old stamp
    std::fill(seen_.begin(), seen_.end(), 0u);
    stamp_ = 1;
  }
  Vec3 lo, hi;
  boundingBox(planned[0].corners, lo, hi);
  for (const PlannedFace& p : planned.subspan(1)) {
    Vec3 l, h;
    boundingBox(p.corners, l, h);
    lo = {std::min(lo.x, l.x), std::min(lo.y, l.y), std::min(lo.z, l.z)};
    hi = {std::max(hi.x, h.x), std::max(hi.y, h.y), std::max(hi.z, h.z)};
  }
  if (faces_.empty()) rebuild(mesh);
  const Range r = cells(lo, hi);
  for (int z = r.lo[2]; z <= r.hi[2]; ++z)
    for (int y = r.lo[1]; y <= r.hi[1]; ++y)
      for (int x = r.lo[0]; x <= r.hi[0]; ++x) {
        for (const Entry& e : faces_[index(x, y, z)]) {
          // A stale entry's box may miss the face's current place; the face's fresh entry then
          // holds it, so skipping here (before marking the face seen) loses nothing.
          if (e.hi[0] < lo.x || e.lo[0] > hi.x || e.hi[1] < lo.y || e.lo[1] > hi.y || e.hi[2] < lo.z || e.lo[2] > hi.z) continue;
          const std::uint32_t g = e.face;
          if (seen_[g] == stamp_) continue;
          seen_[g] = stamp_;
          if (!mesh.faceAlive(g) || std::find(ignore.begin(), ignore.end(), g) != ignore.end()) continue;
          const Face& other = mesh.face(g);
          const Triangle there = corners(mesh, g);
          for (const PlannedFace& p : planned) {
            if (!boxesOverlap(p.corners, there)) continue;
            int shared = 0, cornerHere = 0, cornerThere = 0;
            for (int i = 0; i < 3; ++i)
              for (int k = 0; k < 3; ++k)
                if (other[std::size_t(i)] == p.ids[std::size_t(k)]) ++shared, cornerThere = i, cornerHere = k;
            // Faces sharing an edge are neighbours: the normal-turn bounds keep those apart.
            if (shared == 0 && trianglesIntersect(p.corners, there)) return g;
            if (shared == 1 && trianglesMeetBeyondCorner(p.corners, cornerHere, there, cornerThere)) return g;
          }
        }
      }
  return kNone;
}

}  // namespace blobvk::mesh::remesh
