#include "blobvk/cpu_simd/sharp_features.h"

#include <Eigen/Eigenvalues>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace blobvk::cpu {
namespace {

using glm::dvec3;
using Triangle = std::array<std::uint32_t, 3>;

dvec3 toD(const mesh::Float3& f) { return {f.x, f.y, f.z}; }
mesh::Float3 toF(const dvec3& v) { return {float(v.x), float(v.y), float(v.z)}; }

constexpr std::uint64_t kNoCell = ~std::uint64_t(0);

// The grid's cells and points, and the edge a vertex key names.
struct Lattice {
  std::int64_t cells[3], points[3];

  explicit Lattice(const blobtree::GridSpec& grid)
      : cells{grid.cells.x, grid.cells.y, grid.cells.z}, points{grid.cells.x + 1, grid.cells.y + 1, grid.cells.z + 1} {}

  struct Edge {
    std::int64_t at[3];
    int axis;
  };
  Edge edge(std::uint64_t key) const {
    const std::uint64_t p = key / 3;
    const auto nx = std::uint64_t(points[0]), ny = std::uint64_t(points[1]);
    return {{std::int64_t(p % nx), std::int64_t((p / nx) % ny), std::int64_t(p / (nx * ny))}, int(key % 3)};
  }
  void cellCoords(std::uint64_t index, std::int64_t (&c)[3]) const {
    const auto nx = std::uint64_t(cells[0]), ny = std::uint64_t(cells[1]);
    c[0] = std::int64_t(index % nx), c[1] = std::int64_t((index / nx) % ny), c[2] = std::int64_t(index / (nx * ny));
  }
  std::uint64_t cellIndex(const std::int64_t c[3]) const {
    return (std::uint64_t(c[2]) * std::uint64_t(cells[1]) + std::uint64_t(c[1])) * std::uint64_t(cells[0]) +
           std::uint64_t(c[0]);
  }
  // Whether edge e is one of cell c's twelve.
  static bool cellHasEdge(const std::int64_t c[3], const Edge& e) {
    for (int a = 0; a < 3; ++a) {
      const std::int64_t d = e.at[a] - c[a];
      if (a == e.axis ? d != 0 : (d != 0 && d != 1)) return false;
    }
    return true;
  }
  // The one cell that has the edges of all three corners (a marching-cubes triangle's cell);
  // kNoCell when none does, or when two do (a triangle lying in a cell face).
  std::uint64_t triangleCell(const Edge (&e)[3]) const {
    std::uint64_t found = kNoCell;
    int matches = 0;
    const int a1 = (e[0].axis + 1) % 3, a2 = (e[0].axis + 2) % 3;
    for (int s = 0; s < 4; ++s) {
      std::int64_t c[3] = {e[0].at[0], e[0].at[1], e[0].at[2]};
      c[a1] -= s & 1;
      c[a2] -= s >> 1;
      bool inside = true;
      for (int a = 0; a < 3; ++a) inside = inside && c[a] >= 0 && c[a] < cells[a];
      if (!inside || !cellHasEdge(c, e[1]) || !cellHasEdge(c, e[2])) continue;
      ++matches;
      found = cellIndex(c);
    }
    return matches == 1 ? found : kNoCell;
  }
};

dvec3 triangleNormal(const dvec3& a, const dvec3& b, const dvec3& c) { return glm::cross(b - a, c - a); }

// One cell's patch replaced by a fan, if it qualifies.
struct Fan {
  dvec3 position, normal, colour;
  std::vector<std::uint32_t> loop;  // the patch's boundary, in the triangles' winding
};

class FeaturePass {
 public:
  FeaturePass(mesh::TriMesh& mesh, const blobtree::GridSpec& grid, const FeatureOptions& options)
      : mesh_(mesh), grid_(grid), lattice_(grid), options_(options),
        cosCrease_(std::cos(double(options.creaseDegrees) * 3.14159265358979323846 / 180.0)) {}

  void run(FeatureReport& report) {
    // Each triangle's cell, once; input out of cell order is refused before anything changes.
    std::vector<std::uint64_t> cellOfTriangle(mesh_.triangles.size());
    std::uint64_t previousCell = 0;
    for (std::size_t t = 0; t < cellOfTriangle.size(); ++t) {
      const std::uint64_t c = cellOf(mesh_.triangles[t]);
      if (c != kNoCell) {
        if (c < previousCell)
          throw std::invalid_argument("sharp features: the triangles are not in cell order (give the polygonizer's mesh, "
                                      "before simplification or reordering)");
        previousCell = c;
      }
      cellOfTriangle[t] = c;
    }
    const auto input = std::move(mesh_.triangles);
    decltype(mesh_.triangles) output;
    output.reserve(input.size() + input.size() / 4);
    fanOf_.clear();
    fanOf_.reserve(output.capacity());
    const std::uint32_t firstFeature = std::uint32_t(mesh_.positions.size());
    for (std::size_t t = 0; t < input.size();) {
      const std::uint64_t c = cellOfTriangle[t];
      std::size_t end = t + 1;
      while (end < input.size() && cellOfTriangle[end] == c) ++end;
      std::optional<Fan> fan;
      if (c != kNoCell) {
        std::int64_t cell[3];
        lattice_.cellCoords(c, cell);
        fan = fanFor(std::span<const Triangle>(input.data() + t, end - t), cell, report);
      }
      if (!fan) {
        output.insert(output.end(), input.begin() + std::ptrdiff_t(t), input.begin() + std::ptrdiff_t(end));
        fanOf_.insert(fanOf_.end(), end - t, kNotFan);
      } else {
        const auto f = std::uint32_t(mesh_.positions.size());
        addVertex(*fan, c);
        for (std::size_t i = 0; i < fan->loop.size(); ++i) {
          output.push_back({fan->loop[i], fan->loop[(i + 1) % fan->loop.size()], f});
          fanOf_.push_back(f);
        }
        ++report.featureVertices;
      }
      t = end;
    }
    mesh_.triangles = std::move(output);
    if (options_.flipEdges && mesh_.positions.size() > firstFeature) flipAlongCreases(report);
  }

 private:
  static constexpr std::uint32_t kNotFan = ~std::uint32_t(0);

  std::uint64_t cellOf(const Triangle& t) const {
    const Lattice::Edge e[3] = {lattice_.edge(mesh_.edgeKeys[t[0]]), lattice_.edge(mesh_.edgeKeys[t[1]]),
                                lattice_.edge(mesh_.edgeKeys[t[2]])};
    return lattice_.triangleCell(e);
  }

  std::optional<Fan> fanFor(std::span<const Triangle> patch, const std::int64_t (&cell)[3], FeatureReport& report) const {
    // The patch's vertices and whether their normals disagree.
    std::vector<std::uint32_t> verts;
    for (const Triangle& t : patch)
      for (std::uint32_t v : t)
        if (std::find(verts.begin(), verts.end(), v) == verts.end()) verts.push_back(v);
    double minCos = 1.0;
    for (std::uint32_t v : verts)
      if (glm::length(toD(mesh_.normals[v])) < 0.5) return std::nullopt;  // no gradient to fit
    for (std::size_t a = 0; a < verts.size(); ++a)
      for (std::size_t b = a + 1; b < verts.size(); ++b)
        minCos = std::min(minCos, glm::dot(toD(mesh_.normals[verts[a]]), toD(mesh_.normals[verts[b]])));
    if (minCos >= cosCrease_) return std::nullopt;
    ++report.featureCells;

    // One disc only: its boundary is one loop through every boundary edge (V - E + F = 1).
    std::vector<std::pair<std::uint32_t, std::uint32_t>> directed;
    for (const Triangle& t : patch)
      for (int i = 0; i < 3; ++i) directed.emplace_back(t[i], t[(i + 1) % 3]);
    std::unordered_map<std::uint32_t, std::uint32_t> next;
    for (const auto& [u, v] : directed)
      if (std::find(directed.begin(), directed.end(), std::make_pair(v, u)) == directed.end() && !next.emplace(u, v).second) {
        ++report.rejected, ++report.notADisc;
        return std::nullopt;
      }
    const std::size_t interiorEdges = (directed.size() - next.size()) / 2;
    if (next.empty() ||
        long(verts.size()) - long(next.size() + interiorEdges) + long(patch.size()) != 1) {
      ++report.rejected, ++report.notADisc;
      return std::nullopt;
    }
    Fan fan;
    std::uint32_t at = next.begin()->first;
    // Start the loop at its smallest vertex so the fan does not depend on hash order.
    for (const auto& [u, v] : next) at = std::min(at, u);
    for (std::size_t i = 0; i < next.size(); ++i) {
      fan.loop.push_back(at);
      at = next.at(at);
    }
    if (at != fan.loop.front() || fan.loop.size() != verts.size()) {
      ++report.rejected, ++report.notADisc;
      return std::nullopt;
    }

    // The point closest to every tangent plane: least squares about the vertices' mean, with
    // the directions the planes do not fix left at the mean.
    dvec3 mean(0.0), normal(0.0), colour(0.0);
    for (std::uint32_t v : verts) {
      mean += toD(mesh_.positions[v]);
      normal += toD(mesh_.normals[v]);
      if (!mesh_.colours.empty()) colour += toD(mesh_.colours[v]);
    }
    mean /= double(verts.size());
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    for (std::uint32_t v : verts) {
      const dvec3 n = glm::normalize(toD(mesh_.normals[v]));
      const Eigen::Vector3d ne(n.x, n.y, n.z);
      ata += ne * ne.transpose();
      atb += ne * glm::dot(n, toD(mesh_.positions[v]) - mean);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(ata);
    const double largest = eigen.eigenvalues()(2);
    const double floor = double(options_.singularRatio) * double(options_.singularRatio) * largest;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
      const double lambda = eigen.eigenvalues()(i);
      if (lambda > floor && lambda > 0.0) x += eigen.eigenvectors().col(i) * (eigen.eigenvectors().col(i).dot(atb) / lambda);
    }
    fan.position = mean + dvec3(x(0), x(1), x(2));
    // A fit outside the cell (the crease's corner lies in a neighbour) is clamped into it: the
    // fan stays inside the cell, so it cannot cross a neighbour's triangles.
    const double h = double(grid_.cellSize);
    for (int a = 0; a < 3; ++a) {
      const double lo = double(grid_.origin[a]) + h * double(cell[a]);
      fan.position[a] = std::clamp(fan.position[a], lo, lo + h);
    }
    // No fold: each fan triangle faces the way its two boundary vertices' normals do.
    for (std::size_t i = 0; i < fan.loop.size(); ++i) {
      const std::uint32_t u = fan.loop[i], v = fan.loop[(i + 1) % fan.loop.size()];
      const dvec3 n = triangleNormal(toD(mesh_.positions[u]), toD(mesh_.positions[v]), fan.position);
      if (glm::dot(n, toD(mesh_.normals[u]) + toD(mesh_.normals[v])) <= 0.0 || glm::length(n) <= 1e-12 * h * h) {
        ++report.rejected, ++report.folds;
        return std::nullopt;
      }
    }
    const double length = glm::length(normal);
    fan.normal = length > 0.0 ? normal / length : normal;
    fan.colour = colour / double(verts.size());
    return fan;
  }

  void addVertex(const Fan& fan, std::uint64_t cell) {
    mesh_.positions.push_back(toF(fan.position));
    mesh_.normals.push_back(toF(fan.normal));
    if (!mesh_.colours.empty()) mesh_.colours.push_back(toF(fan.colour));
    mesh_.edgeKeys.push_back(3 * grid_.pointCount() + cell);
  }

  // Two fans meeting on a boundary edge (u, v): triangles (u, v, f) and (v, u, g) become
  // (u, g, f) and (v, f, g), so the crease runs f - g instead of zig-zagging through u and v.
  // Taken only where both new triangles face the way the two old ones and u's and v's normals do.
  void flipAlongCreases(FeatureReport& report) {
    auto& tris = mesh_.triangles;
    auto edgeKey = [](std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; };
    std::unordered_map<std::uint64_t, std::size_t> base;  // fan triangle by its (u, v)
    for (std::size_t t = 0; t < tris.size(); ++t)
      if (fanOf_[t] != kNotFan) base.emplace(edgeKey(tris[t][0], tris[t][1]), t);
    std::unordered_set<std::uint64_t> joined;  // feature pairs already joined
    std::vector<bool> flipped(tris.size(), false);
    auto p = [&](std::uint32_t v) { return toD(mesh_.positions[v]); };
    auto n = [&](std::uint32_t v) { return toD(mesh_.normals[v]); };
    for (std::size_t t = 0; t < tris.size(); ++t) {
      if (fanOf_[t] == kNotFan || flipped[t]) continue;
      const std::uint32_t u = tris[t][0], v = tris[t][1], f = tris[t][2];
      const auto other = base.find(edgeKey(v, u));
      if (other == base.end()) continue;
      const std::size_t s = other->second;
      if (flipped[s] || fanOf_[s] == f) continue;
      const std::uint32_t g = tris[s][2];
      if (joined.count(edgeKey(std::min(f, g), std::max(f, g)))) continue;
      const dvec3 before = triangleNormal(p(u), p(v), p(f)) + triangleNormal(p(v), p(u), p(g));
      const dvec3 a = triangleNormal(p(u), p(g), p(f)), b = triangleNormal(p(v), p(f), p(g));
      if (glm::dot(a, before) <= 0.0 || glm::dot(b, before) <= 0.0 || glm::dot(a, n(u)) <= 0.0 ||
          glm::dot(b, n(v)) <= 0.0)
        continue;
      tris[t] = {u, g, f};
      tris[s] = {v, f, g};
      flipped[t] = flipped[s] = true;
      joined.insert(edgeKey(std::min(f, g), std::max(f, g)));
      ++report.flips;
    }
  }

  mesh::TriMesh& mesh_;
  const blobtree::GridSpec& grid_;
  Lattice lattice_;
  FeatureOptions options_;
  double cosCrease_;
  std::vector<std::uint32_t> fanOf_;  // per output triangle: its fan's feature vertex, or kNotFan
};

}  // namespace

void placeSharpFeatures(mesh::TriMesh& mesh, const blobtree::GridSpec& grid, const FeatureOptions& options,
                        FeatureReport* report) {
  if (mesh.edgeKeys.size() != mesh.positions.size())
    throw std::invalid_argument("sharp features: the mesh has no edge keys (it must come from a polygonizer)");
  if (mesh.normals.size() != mesh.positions.size())
    throw std::invalid_argument("sharp features: the mesh has no normals (polygonize with normals)");
  if (!(options.creaseDegrees > 0.0f && options.creaseDegrees < 180.0f))
    throw std::invalid_argument("sharp features: the crease angle must lie between 0 and 180 degrees, not " +
                                std::to_string(options.creaseDegrees));
  FeatureReport local;
  FeaturePass(mesh, grid, options).run(report ? *report : local);
}

}  // namespace blobvk::cpu
