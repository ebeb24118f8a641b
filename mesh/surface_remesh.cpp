#include "mesh/surface_remesh.h"

#include "mesh/checks.h"
#include "mesh/surface_remesh_topology.h"

#include <algorithm>
#include <cmath>
#include <numbers>
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
      : mesh_(surface), options_(options), stats_(stats), cosTurn_(std::cos(options.maxNormalTurnDegrees * kDegrees)) {}

  TriMesh run() {
    const double length = options_.targetEdgeLength;
    for (int i = 0; i < options_.iterations; ++i) {
      splitLongEdges(4.0 / 3.0 * length);
      collapseShortEdges(0.8 * length, 4.0 / 3.0 * length);
      flipForAngles();
      relax();
    }
    flipForAngles();
    return mesh_.toTriMesh();
  }

 private:
  Vec3 project(const Vec3& p) const {
    if (!options_.project) return p;
    const Double3 q = options_.project(Double3{p.x, p.y, p.z});
    const Vec3 moved{q.x, q.y, q.z};
    // A projection that jumps far (a Newton step where the gradient nearly vanishes) would fold
    // the surface; the unprojected point is the safer choice.
    const double jump = remesh::length(moved - p);
    return jump <= 0.5 * options_.targetEdgeLength ? moved : p;
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

  void splitLongEdges(double high) {
    forEachEdge([&](std::uint32_t a, std::uint32_t b) {
      if (edgeLength(a, b) <= high) return false;
      mesh_.split(a, b, project((mesh_.positions[a] + mesh_.positions[b]) * 0.5));
      ++stats_.splits;
      return true;
    });
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
      if (!collapseIsSafe(a, b, p, high)) return false;
      mesh_.collapse(a, b, p);
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
        mesh_.flip(a, b);
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
      target[v] = project(mesh_.positions[v] + move - vertexNormal[v] * remesh::dot(vertexNormal[v], move));
    }
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
  }

  EditableMesh mesh_;
  const SurfaceRemeshOptions& options_;
  SurfaceRemeshStats& stats_;
  double cosTurn_;
  std::vector<std::uint32_t> ringVertices_, ringFaces_;  // scratch
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

}  // namespace blobvk::mesh
