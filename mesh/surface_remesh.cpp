#include "blobvk/mesh/surface_remesh.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/surface_remesh_intersections.h"
#include "blobvk/mesh/surface_remesh_topology.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <stdexcept>

namespace blobvk::mesh {
namespace {

using remesh::EditableMesh;
using remesh::Face;
using remesh::Vec3;

constexpr double kDegrees = std::numbers::pi / 180;

class Remesher {
 public:
  Remesher(const TriMesh& surface, const SurfaceRemeshOptions& options, SurfaceRemeshStats& stats)
      : mesh_(surface), options_(options), stats_(stats), cosTurn_(std::cos(options.maxNormalTurnDegrees * kDegrees)) {
    if (options.preventSelfIntersections) grid_.emplace(options.targetEdgeLength);
  }

  TriMesh run() {
    const double length = options_.targetEdgeLength;
    // The grid is rebuilt before each pass: it drops the entries that edits left stale (a
    // collapse re-inserts ~8 faces), which otherwise slowed every query of the pass down.
    const auto rebuildGrid = [&] {
      if (grid_) grid_->rebuild(mesh_);
    };
    for (int i = 0; i < options_.iterations; ++i) {
      rebuildGrid();
      splitLongEdges(4.0 / 3.0 * length);
      rebuildGrid();
      collapseShortEdges(0.8 * length, 4.0 / 3.0 * length);
      rebuildGrid();
      flipForAngles();
      relax();  // rebuilds the grid itself once the vertices have moved
    }
    rebuildGrid();
    flipForAngles();
    return mesh_.toTriMesh();
  }

 private:
  Vec3 project(const Vec3& p) {
    std::vector<Vec3>& one = scratchPoints_;
    one.assign(1, p);
    projectAll(one);
    return one[0];
  }

  // Projects the points in place, in one batch call when the caller gave one.
  void projectAll(std::vector<Vec3>& points) {
    if (!options_.projectBatch && !options_.project) return;
    batch_.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) batch_[i] = Double3{points[i].x, points[i].y, points[i].z};
    if (options_.projectBatch) {
      options_.projectBatch(batch_);
    } else {
      for (Double3& q : batch_) q = options_.project(q);
    }
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3 moved{batch_[i].x, batch_[i].y, batch_[i].z};
      // A projection that jumps far (a Newton step where the gradient nearly vanishes) would
      // fold the surface; the unprojected point is the safer choice.
      if (remesh::length(moved - points[i]) <= 0.5 * options_.targetEdgeLength) points[i] = moved;
    }
  }

  // Calls visit(a, b) once per undirected edge alive at the time it is reached, in face order
  // (faces appended by a split are visited too). visit returns whether it edited the mesh.
  template <class Visit>
  void forEachEdge(Visit visit) {
    for (std::uint32_t f = 0; f < mesh_.faceSlots(); ++f) {
      for (int k = 0; k < 3 && mesh_.faceAlive(f); ++k) {
        const Face& t = mesh_.face(f);
        const std::uint32_t a = t[std::size_t(k)], b = t[std::size_t((k + 1) % 3)];
        if (a < b && visit(a, b)) k = -1;  // face f changed: look at its edges again
      }
    }
  }

  double edgeLength(std::uint32_t a, std::uint32_t b) const { return remesh::length(mesh_.positions[a] - mesh_.positions[b]); }

  // New vertices start at edge midpoints and are projected together at the end of the pass.
  void splitLongEdges(double high) {
    std::vector<std::uint32_t> added;
    forEachEdge([&](std::uint32_t a, std::uint32_t b) {
      if (edgeLength(a, b) <= high) return false;
      added.push_back(mesh_.split(a, b, (mesh_.positions[a] + mesh_.positions[b]) * 0.5));
      insertRing(added.back());  // in the old faces' planes: crosses nothing new
      ++stats_.splits;
      return true;
    });
    std::vector<Vec3> points(added.size());
    for (std::size_t i = 0; i < added.size(); ++i) points[i] = mesh_.positions[added[i]];
    const std::vector<Vec3> midpoints = points;
    projectAll(points);
    for (std::size_t i = 0; i < added.size(); ++i) mesh_.positions[added[i]] = points[i];
    undoCrossingMoves(added, midpoints);
  }

  void insertRing(std::uint32_t v) {
    if (!grid_) return;
    mesh_.ring(v, ringVertices_, ringFaces_);
    for (std::uint32_t g : ringFaces_) grid_->insert(mesh_, g);
  }

  remesh::Triangle corners(std::uint32_t f) const {
    const Face& t = mesh_.face(f);
    return {mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]};
  }

  // The vertices in `moved` have just moved from `before`: moves are undone wherever a face
  // around a moved vertex crosses another face (both faces' moved vertices go back). The
  // state before the moves was free of crossings, so undoing converges to a state that is too.
  // A worklist of faces to test: every face around a moved vertex, then the faces around each
  // vertex put back (its neighbours' faces changed shape).
  void undoCrossingMoves(const std::vector<std::uint32_t>& moved, const std::vector<Vec3>& before) {
    if (!grid_ || moved.empty()) return;
    std::unordered_map<std::uint32_t, std::size_t> slot;  // vertex -> index in moved, while still moved
    for (std::size_t i = 0; i < moved.size(); ++i) slot.emplace(moved[i], i);
    std::vector<std::uint32_t> work;
    const bool most = 4 * moved.size() > mesh_.positions.size();
    if (most) grid_->rebuild(mesh_);
    for (std::uint32_t v : moved) {
      mesh_.ring(v, ringVertices_, ringFaces_);
      for (std::uint32_t g : ringFaces_) {
        if (!most) grid_->insert(mesh_, g);
        work.push_back(g);
      }
    }
    std::sort(work.begin(), work.end());
    work.erase(std::unique(work.begin(), work.end()), work.end());
    std::reverse(work.begin(), work.end());  // popped from the back: lowest face first
    const auto putBack = [&](std::uint32_t f) {
      for (std::uint32_t v : mesh_.face(f)) {
        const auto it = slot.find(v);
        if (it == slot.end()) continue;
        mesh_.positions[v] = before[it->second];
        slot.erase(it);
        ++stats_.undoneMoves;
        mesh_.ring(v, ringVertices_, ringFaces_);
        for (std::uint32_t g : ringFaces_) {
          grid_->insert(mesh_, g);
          work.push_back(g);
        }
      }
    };
    while (!work.empty()) {
      const std::uint32_t f = work.back();
      work.pop_back();
      const std::uint32_t self[1] = {f};
      const std::uint32_t g = grid_->crossedFace(mesh_, mesh_.face(f), corners(f), self);
      if (g == remesh::kNone) continue;
      putBack(f);
      putBack(g);
    }
  }

  // Whether the faces around a and b, with both at p, would cross a face elsewhere.
  bool collapseCrosses(std::uint32_t a, std::uint32_t b, const Vec3& p) {
    if (!grid_) return false;
    std::vector<std::uint32_t>& around = collapseFaces_;
    around.clear();
    for (std::uint32_t v : {a, b}) {
      mesh_.ring(v, ringVertices_, ringFaces_);
      around.insert(around.end(), ringFaces_.begin(), ringFaces_.end());
    }
    std::vector<remesh::PlannedFace>& planned = plannedFaces_;
    planned.clear();
    for (std::uint32_t g : around) {
      Face ids = mesh_.face(g);
      if (std::find(ids.begin(), ids.end(), a) != ids.end() && std::find(ids.begin(), ids.end(), b) != ids.end()) continue;  // removed
      remesh::Triangle t = corners(g);
      for (int k = 0; k < 3; ++k)
        if (ids[std::size_t(k)] == a || ids[std::size_t(k)] == b) ids[std::size_t(k)] = b, t[std::size_t(k)] = p;
      planned.push_back({ids, t});
    }
    return grid_->crossedFace(mesh_, planned, around) != remesh::kNone;
  }

  // Whether moving the vertices of `faces` listed in `moved` to p keeps each face's normal within
  // the turn bound, non-degenerate, and keeps edges to p shorter than `high`.
  bool collapseIsSafe(std::uint32_t a, std::uint32_t b, const Vec3& p, double high) {
    for (std::uint32_t v : {a, b}) {
      mesh_.ring(v, ringVertices_, ringFaces_);
      for (std::uint32_t x : ringVertices_)
        if (x != a && x != b && remesh::length(mesh_.positions[x] - p) > high) return false;
      for (std::uint32_t g : ringFaces_) {
        const Face& t = mesh_.face(g);
        if (std::find(t.begin(), t.end(), a) != t.end() && std::find(t.begin(), t.end(), b) != t.end()) continue;
        Vec3 corner[3];
        for (int k = 0; k < 3; ++k) corner[k] = t[std::size_t(k)] == v ? p : mesh_.positions[t[std::size_t(k)]];
        const Vec3 n = remesh::normalized(remesh::cross(corner[1] - corner[0], corner[2] - corner[0]));
        if (remesh::dot(n, n) == 0 || remesh::dot(n, mesh_.faceNormal(g)) < cosTurn_) return false;
      }
    }
    return true;
  }

  void collapseShortEdges(double low, double high) {
    forEachEdge([&](std::uint32_t a, std::uint32_t b) {
      if (edgeLength(a, b) >= low || !mesh_.collapseKeepsManifold(a, b)) return false;
      const Vec3 p = project((mesh_.positions[a] + mesh_.positions[b]) * 0.5);
      if (!collapseIsSafe(a, b, p, high) || collapseCrosses(a, b, p)) return false;
      mesh_.collapse(a, b, p);
      insertRing(b);
      ++stats_.collapses;
      return true;
    });
  }

  // Flips an edge where that raises the smaller angle of its two triangles (the local Delaunay
  // criterion on a flat quad), unless the new triangles would fold against each other or turn
  // away from the area-weighted normal of the old pair (a sliver's own normal is noise).
  void flipForAngles() {
    for (int sweep = 0; sweep < 10; ++sweep) {
      std::size_t flips = 0;
      forEachEdge([&](std::uint32_t a, std::uint32_t b) {
        const std::uint32_t f = mesh_.faceOf(a, b), e = mesh_.faceOf(b, a);
        const std::uint32_t c = mesh_.third(f, a, b), d = mesh_.third(e, b, a);
        const auto& p = mesh_.positions;
        const double before = std::min(remesh::minAngle(p[a], p[b], p[c]), remesh::minAngle(p[b], p[a], p[d]));
        const double after = std::min(remesh::minAngle(p[c], p[a], p[d]), remesh::minAngle(p[d], p[b], p[c]));
        if (after <= before + 1e-3) return false;  // the margin stops flip cycles on near-ties
        const Vec3 oldNormal = remesh::normalized(remesh::cross(p[b] - p[a], p[c] - p[a]) + remesh::cross(p[a] - p[b], p[d] - p[b]));
        const Vec3 n1 = remesh::normalized(remesh::cross(p[a] - p[c], p[d] - p[c]));
        const Vec3 n2 = remesh::normalized(remesh::cross(p[b] - p[d], p[c] - p[d]));
        if (remesh::dot(n1, n2) < cosTurn_ || remesh::dot(n1, oldNormal) < cosTurn_ || remesh::dot(n2, oldNormal) < cosTurn_) return false;
        if (!mesh_.flipKeepsManifold(a, b)) return false;
        if (grid_) {
          const std::uint32_t replaced[2] = {f, e};
          const remesh::PlannedFace planned[2] = {{{c, a, d}, {p[c], p[a], p[d]}}, {{d, b, c}, {p[d], p[b], p[c]}}};
          if (grid_->crossedFace(mesh_, planned, replaced) != remesh::kNone) return false;
        }
        mesh_.flip(a, b);
        if (grid_) grid_->insert(mesh_, f), grid_->insert(mesh_, e);
        ++flips;
        return false;  // face f now holds other edges; the next sweep looks at them
      });
      stats_.flips += flips;
      if (flips == 0) break;
    }
  }

  // Moves every vertex towards the centroid of its neighbours within its tangent plane, then onto
  // the surface (Jacobi: all moves from the old positions, so the order does not matter). A move
  // that would turn a face against the normals of its corners is undone.
  void relax() {
    const std::size_t n = mesh_.positions.size();
    std::vector<Vec3> vertexNormal(n), target(n);
    for (std::uint32_t v = 0; v < n; ++v) {
      if (!mesh_.vertexAlive(v)) continue;
      mesh_.ring(v, ringVertices_, ringFaces_);
      Vec3 centroid, normal;
      for (std::uint32_t x : ringVertices_) centroid = centroid + mesh_.positions[x];
      centroid = centroid * (1.0 / double(ringVertices_.size()));
      for (std::uint32_t g : ringFaces_) {
        const Face& t = mesh_.face(g);
        normal = normal + remesh::cross(mesh_.positions[t[1]] - mesh_.positions[t[0]], mesh_.positions[t[2]] - mesh_.positions[t[0]]);
      }
      vertexNormal[v] = remesh::normalized(normal);
      const Vec3 move = centroid - mesh_.positions[v];
      target[v] = mesh_.positions[v] + move - vertexNormal[v] * remesh::dot(vertexNormal[v], move);
    }
    std::vector<std::uint32_t> alive;
    std::vector<Vec3> moved;
    for (std::uint32_t v = 0; v < n; ++v)
      if (mesh_.vertexAlive(v)) alive.push_back(v), moved.push_back(target[v]);
    projectAll(moved);
    for (std::size_t i = 0; i < alive.size(); ++i) target[alive[i]] = moved[i];
    const std::vector<Vec3> old = mesh_.positions;
    for (std::uint32_t v = 0; v < n; ++v)
      if (mesh_.vertexAlive(v)) mesh_.positions[v] = target[v];
    for (int round = 0; round < 4; ++round) {
      bool reverted = false;
      for (std::uint32_t f = 0; f < mesh_.faceSlots(); ++f) {
        if (!mesh_.faceAlive(f)) continue;
        const Face& t = mesh_.face(f);
        const Vec3 reference = vertexNormal[t[0]] + vertexNormal[t[1]] + vertexNormal[t[2]];
        if (remesh::dot(mesh_.faceNormal(f), remesh::normalized(reference)) >= 0.2) continue;
        for (std::uint32_t v : t) {
          reverted = reverted || !(mesh_.positions[v] == old[v]);
          mesh_.positions[v] = old[v];
        }
      }
      if (!reverted) break;
    }
    std::vector<std::uint32_t> movedVertices;
    std::vector<Vec3> from;
    for (std::uint32_t v = 0; v < n; ++v)
      if (mesh_.vertexAlive(v) && !(mesh_.positions[v] == old[v])) movedVertices.push_back(v), from.push_back(old[v]);
    undoCrossingMoves(movedVertices, from);
  }

  EditableMesh mesh_;
  const SurfaceRemeshOptions& options_;
  SurfaceRemeshStats& stats_;
  double cosTurn_;
  std::vector<std::uint32_t> ringVertices_, ringFaces_;  // scratch
  std::vector<Vec3> scratchPoints_;
  std::vector<std::uint32_t> collapseFaces_;
  std::vector<remesh::PlannedFace> plannedFaces_;
  std::optional<remesh::FaceGrid> grid_;  // only with options.preventSelfIntersections
  std::vector<Double3> batch_;
};

}  // namespace

double minTriangleAngleDegrees(const TriMesh& mesh) {
  double best = 180;
  for (const auto& t : mesh.triangles) {
    const auto at = [&](int k) {
      const Float3& p = mesh.positions[t[std::size_t(k)]];
      return Vec3{p.x, p.y, p.z};
    };
    best = std::min(best, remesh::minAngle(at(0), at(1), at(2)) / kDegrees);
  }
  return best;
}

TriMesh remeshSurface(const TriMesh& surface, const SurfaceRemeshOptions& options, SurfaceRemeshStats* stats) {
  if (!(options.targetEdgeLength > 0)) throw std::invalid_argument("remeshSurface: the target edge length must be > 0");
  if (options.iterations < 0) throw std::invalid_argument("remeshSurface: the iteration count must be >= 0");
  const MeshReport report = checkMesh(surface);
  if (surface.triangles.empty() || !report.watertight() || report.unreferencedVertices > 0)
    throw std::invalid_argument("remeshSurface: the surface must be closed, manifold and oriented with no unused vertices (" +
                                report.summary() + ")");
  SurfaceRemeshStats local;
  SurfaceRemeshStats& s = stats ? *stats : local;
  s = {};
  s.minAngleBeforeDegrees = minTriangleAngleDegrees(surface);
  TriMesh out = Remesher(surface, options, s).run();
  s.minAngleAfterDegrees = minTriangleAngleDegrees(out);
  return out;
}

SurfaceProjection isoSurfaceProjection(std::function<double(const Double3&)> field, double iso, double h, int steps) {
  if (!(h > 0) || steps < 1) throw std::invalid_argument("isoSurfaceProjection: needs a positive step and at least one iteration");
  return [field = std::move(field), iso, h, steps](const Double3& start) {
    Double3 p = start;
    for (int i = 0; i < steps; ++i) {
      const double offset = field(p) - iso;
      const Double3 g{(field({p.x + h, p.y, p.z}) - field({p.x - h, p.y, p.z})) / (2 * h),
                      (field({p.x, p.y + h, p.z}) - field({p.x, p.y - h, p.z})) / (2 * h),
                      (field({p.x, p.y, p.z + h}) - field({p.x, p.y, p.z - h})) / (2 * h)};
      const double g2 = g.x * g.x + g.y * g.y + g.z * g.z;
      if (!(g2 > 0)) break;
      const double s = offset / g2;
      p = {p.x - s * g.x, p.y - s * g.y, p.z - s * g.z};
    }
    return p;
  };
}

SurfaceProjectionBatch isoSurfaceProjectionBatch(FieldBatch field, double iso, double h, int steps) {
  if (!(h > 0) || steps < 1) throw std::invalid_argument("isoSurfaceProjectionBatch: needs a positive step and at least one iteration");
  return [field = std::move(field), iso, h, steps](std::vector<Double3>& points) {
    std::vector<Double3> samples(7 * points.size());
    std::vector<double> values;
    std::vector<char> done(points.size(), 0);  // a vanishing gradient stops a point, as in the scalar form
    for (int i = 0; i < steps; ++i) {
      for (std::size_t k = 0; k < points.size(); ++k) {
        const Double3& p = points[k];
        Double3* s = &samples[7 * k];
        s[0] = p;
        s[1] = {p.x + h, p.y, p.z}, s[2] = {p.x - h, p.y, p.z};
        s[3] = {p.x, p.y + h, p.z}, s[4] = {p.x, p.y - h, p.z};
        s[5] = {p.x, p.y, p.z + h}, s[6] = {p.x, p.y, p.z - h};
      }
      field(samples, values);
      if (values.size() != samples.size()) throw std::logic_error("isoSurfaceProjectionBatch: the field callback returned a wrong count");
      for (std::size_t k = 0; k < points.size(); ++k) {
        if (done[k]) continue;
        const double* f = &values[7 * k];
        const Double3 g{(f[1] - f[2]) / (2 * h), (f[3] - f[4]) / (2 * h), (f[5] - f[6]) / (2 * h)};
        const double g2 = g.x * g.x + g.y * g.y + g.z * g.z;
        if (!(g2 > 0)) {
          done[k] = 1;
          continue;
        }
        const double s = (f[0] - iso) / g2;
        points[k] = {points[k].x - s * g.x, points[k].y - s * g.y, points[k].z - s * g.z};
      }
    }
  };
}

}  // namespace blobvk::mesh
