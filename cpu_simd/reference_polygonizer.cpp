// Reference marching cubes: the exact rules every other polygonizer must reproduce.
//
// 1. Sampling: f(i, j, k) = blobtree::evaluate(program, grid.point(i, j, k)), each point once.
//    A point is inside when f >= ISO_VALUE.
// 2. Vertices: one per crossing grid edge (its two end points differ in inside-ness). The edge
//    starts at its lower-index point a = point(i, j, k) and ends at b = a + cellSize along axis.
//    t = (ISO - fa) / (fb - fa), kept within [CROSSING_MIN, CROSSING_MAX] (2^-12 from either end:
//    no two vertices on one grid point); position = a with component `axis` replaced by
//    a[axis] + t * (b[axis] - a[axis]), all in float (the other components of b - a are zero).
//    Optional refinement (refineSteps > 0): Illinois regula falsi on the bracket [0, 1] with the
//    end values (fa, fb): each step evaluates at the current t, keeps the sub-bracket that still
//    changes sign, halves the stale end's value when the same end is kept twice, and recomputes t
//    by the secant of the bracket (kept within the same bounds). A step whose value is exactly
//    ISO stops early.
// 3. Order: vertices are numbered in increasing global edge key (pointIndex * 3 + axis), which is
//    the order of a scan over points in index order with axes 0, 1, 2.
// 4. Triangles: for each cell in cell index order (= pointIndex of its lowest corner), the case
//    table's triangles for its configuration, mapped from cell edge ids to vertex ids.
// 5. Attributes: normal = outwardNormal of the analytic gradient (blobtree/gradient.h) and the
//    colour, both from one evaluateGradientColour pass at the final vertex position.
//
// Memory stays at a few z-slabs: field values of three point layers and vertex ids of two, so the
// reference can run grids far larger than a whole-grid index array would allow.
#include "blobvk/cpu_simd/reference_polygonizer.h"

#include "blobvk/cpu_simd/edge_crossing.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/gradient.h"
#include "blobvk/mesh/marching_cubes.h"

#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::cpu {
namespace {

constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

// Parameter t in [0, 1] of the iso crossing on edge a -> b (see rule 2 above).
float crossingParameter(const blobtree::Program& program, glm::vec3 a, int axis, float length,
                        float fa, float fb, int refineSteps) {
  const float iso = layout::ISO_VALUE;
  float t = crossingWithinEdge((iso - fa) / (fb - fa));
  float lo = 0.0f, hi = 1.0f, flo = fa, fhi = fb;
  int keptSide = 0;  // -1: lo kept last step, +1: hi kept last step
  for (int step = 0; step < refineSteps; ++step) {
    glm::vec3 p = a;
    p[axis] = a[axis] + t * length;  // the same expression as the final position
    const float f = blobtree::evaluate(program, p);
    if (f == iso) break;
    // (f >= iso) == (flo >= iso): the crossing lies in [t, hi]
    if ((f >= iso) == (flo >= iso)) {
      lo = t, flo = f;
      if (keptSide == +1) fhi = iso + (fhi - iso) * 0.5f;  // Illinois: hi went stale
      keptSide = +1;
    } else {
      hi = t, fhi = f;
      if (keptSide == -1) flo = iso + (flo - iso) * 0.5f;
      keptSide = -1;
    }
    t = crossingWithinEdge(lo + (iso - flo) / (fhi - flo) * (hi - lo));
  }
  return t;
}

}  // namespace

mesh::TriMesh polygonizeReference(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                  const ReferenceOptions& options) {
  if (!(grid.cellSize > 0.0f))
    throw std::invalid_argument("polygonizeReference: cell size must be positive, got " +
                                std::to_string(grid.cellSize));
  if (grid.cells.x < 0 || grid.cells.y < 0 || grid.cells.z < 0)
    throw std::invalid_argument("polygonizeReference: negative cell count");
  if (options.refineSteps < 0)
    throw std::invalid_argument("polygonizeReference: refineSteps must be >= 0");

  mesh::TriMesh mesh;
  if (grid.cells.x == 0 || grid.cells.y == 0 || grid.cells.z == 0) return mesh;

  const glm::ivec3 pts = grid.points();
  const std::size_t slab = std::size_t(pts.x) * std::size_t(pts.y);
  const float iso = layout::ISO_VALUE;
  // Three field layers (k, k+1, k+2) and two vertex-id layers (k, k+1) in rings.
  std::vector<float> fields(3 * slab);
  std::vector<std::uint32_t> vertexIds(2 * 3 * slab, kNoVertex);
  const auto field = [&](int i, int j, int k) -> float& {
    return fields[std::size_t(k % 3) * slab + std::size_t(j) * std::size_t(pts.x) + std::size_t(i)];
  };
  const auto vertexId = [&](int i, int j, int k, int axis) -> std::uint32_t& {
    return vertexIds[(std::size_t(k % 2) * slab + std::size_t(j) * std::size_t(pts.x) +
                      std::size_t(i)) * 3 + std::size_t(axis)];
  };

  const auto sampleLayer = [&](int k) {
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i) field(i, j, k) = blobtree::evaluate(program, grid.point(i, j, k));
  };

  // Creates the vertices of every crossing edge that starts on layer k, in edge-key order.
  // Needs the fields of layers k and k + 1.
  const auto makeVertices = [&](int k) {
    for (int j = 0; j < pts.y; ++j) {
      for (int i = 0; i < pts.x; ++i) {
        const float fa = field(i, j, k);
        for (int axis = 0; axis < 3; ++axis) {
          std::uint32_t& id = vertexId(i, j, k, axis);
          id = kNoVertex;
          glm::ivec3 end(i, j, k);
          end[axis] += 1;
          if (end[axis] >= pts[axis]) continue;
          const float fb = field(end.x, end.y, end.z);
          if ((fa >= iso) == (fb >= iso)) continue;
          if (mesh.positions.size() >= kNoVertex)
            throw std::length_error("polygonizeReference: more than 2^32 - 1 vertices");
          const glm::vec3 a = grid.point(i, j, k);
          const float length = grid.point(end.x, end.y, end.z)[axis] - a[axis];
          const float t = crossingParameter(program, a, axis, length, fa, fb, options.refineSteps);
          glm::vec3 p = a;
          p[axis] = a[axis] + t * length;
          id = std::uint32_t(mesh.positions.size());
          mesh.positions.push_back({p.x, p.y, p.z});
          mesh.edgeKeys.push_back(grid.edgeKey(i, j, k, axis));
          if (options.normals || options.colours) {
            const blobtree::FieldGradient fg = options.colours ? blobtree::evaluateGradientColour(program, p)
                                                               : blobtree::evaluateGradient(program, p);
            if (options.normals) {
              const glm::vec3 n = blobtree::outwardNormal(fg.gradient);
              mesh.normals.push_back({n.x, n.y, n.z});
            }
            if (options.colours) mesh.colours.push_back({fg.colour.x, fg.colour.y, fg.colour.z});
          }
        }
      }
    }
  };

  const auto& cases = mesh::marchingCubesCases();
  const auto emitCells = [&](int k) {
    for (int j = 0; j < grid.cells.y; ++j) {
      for (int i = 0; i < grid.cells.x; ++i) {
        unsigned config = 0;
        for (int c = 0; c < 8; ++c)
          if (field(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) >= iso) config |= 1u << c;
        const mesh::McCase& mc = cases[config];
        for (int t = 0; t < mc.triangleCount; ++t) {
          std::array<std::uint32_t, 3> tri{};
          for (int v = 0; v < 3; ++v) {
            const int e = mc.edges[std::size_t(t * 3 + v)];
            const std::array<int, 3> s = mesh::mcEdgeStart(e);
            tri[std::size_t(v)] = vertexId(i + s[0], j + s[1], k + s[2], mesh::mcEdgeAxis(e));
          }
          mesh.triangles.push_back(tri);
        }
      }
    }
  };

  sampleLayer(0);
  sampleLayer(1);
  makeVertices(0);
  for (int k = 0; k < grid.cells.z; ++k) {
    // Layer k + 1's vertices need layer k + 2's field; the ring slot of k + 2 held layer k - 1,
    // which no longer matters (cells of layer k only read layers k and k + 1).
    if (k + 2 < pts.z) sampleLayer(k + 2);
    makeVertices(k + 1);
    emitCells(k);
  }
  return mesh;
}

}  // namespace blobvk::cpu
