#include "blobvk/vk/render/raycast_lipschitz.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace blobvk::vk {
namespace {

namespace L = blobvk::layout;

// Largest singular value of the 3x3 part: the square root of the largest eigenvalue of A^T A,
// in closed form for a symmetric 3x3 matrix (Smith 1961), rounded up by a relative 1e-4 so the
// bound stays an upper bound; never above the Frobenius norm.
float matrixStretch(const L::MatrixRecord& m) {
  const double a[3][3] = {{m.r0.x, m.r0.y, m.r0.z}, {m.r1.x, m.r1.y, m.r1.z}, {m.r2.x, m.r2.y, m.r2.z}};
  double s[3][3] = {};
  double frobenius = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) s[i][j] += a[k][i] * a[k][j];
      frobenius += a[i][j] * a[i][j];
    }
  }
  const double p1 = s[0][1] * s[0][1] + s[0][2] * s[0][2] + s[1][2] * s[1][2];
  const double q = (s[0][0] + s[1][1] + s[2][2]) / 3.0;
  double largest = 0.0;
  if (p1 <= 1e-30 * (1.0 + q * q)) {
    largest = std::max({s[0][0], s[1][1], s[2][2]});
  } else {
    const double p2 = (s[0][0] - q) * (s[0][0] - q) + (s[1][1] - q) * (s[1][1] - q) +
                      (s[2][2] - q) * (s[2][2] - q) + 2.0 * p1;
    const double p = std::sqrt(p2 / 6.0);
    double b[3][3];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) b[i][j] = (s[i][j] - (i == j ? q : 0.0)) / p;
    }
    const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) -
                       b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
                       b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    const double r = std::clamp(det / 2.0, -1.0, 1.0);
    largest = q + 2.0 * p * std::cos(std::acos(r) / 3.0);
  }
  return float(std::min(std::sqrt(std::max(largest, 0.0)) * (1.0 + 1e-4), std::sqrt(frobenius)));
}


bool missesBox(const blobtree::Aabb& region, const L::BoxRecord& box) {
  return region.hi.x < box.lo.x || region.hi.y < box.lo.y || region.hi.z < box.lo.z ||
         region.lo.x > box.hi.x || region.lo.y > box.hi.y || region.lo.z > box.hi.z;
}

}  // namespace

LipschitzBound lipschitzBound(const blobtree::Program& program, const blobtree::Aabb& region) {
  constexpr float kWyvillSlope = 1.7173f;  // 96 / (25 sqrt 5), rounded up
  constexpr float kQuadricSlope = 1.5397f;  // 8 / (3 sqrt 3), rounded up
  std::array<float, L::MAX_FIELD_REGISTERS> lip{}, value{};
  // Per point register: stretch (product of warp Jacobian bounds) and, per axis, the largest
  // coordinate magnitude a point of the region can have there (a twist's stretch depends only on
  // the distance from its axis, not on the coordinate along it).
  std::array<float, L::MAX_POINT_REGISTERS> stretch{};
  std::array<glm::vec3, L::MAX_POINT_REGISTERS> reach{};
  stretch[0] = 1.0f;
  for (int c = 0; c < 3; ++c) reach[0][c] = std::max(std::abs(region.lo[c]), std::abs(region.hi[c]));
  const auto identity = [&](std::uint32_t m) { return m == 0 || m >= program.matrices.size(); };

  for (const auto& in : program.code) {
    const std::uint32_t op = in.code.x & 0xffu, dst = in.code.x >> 8, y = in.code.y, z = in.code.z;
    if (op == L::OP_WARP) {
      if (dst >= stretch.size() || z >= stretch.size() || y >= program.warps.size()) continue;
      const auto& w = program.warps[y];
      float s = stretch[z];
      glm::vec3 r = reach[z];
      if (!identity(w.meta.w)) {
        const auto& m = program.matrices[w.meta.w];
        s *= matrixStretch(m);
        // |row . p + t| <= sum |row_j| reach_j + |t|, per output axis.
        const L::vec4 rows[3] = {m.r0, m.r1, m.r2};
        glm::vec3 out;
        for (int i = 0; i < 3; ++i) {
          out[i] = std::abs(rows[i].x) * r.x + std::abs(rows[i].y) * r.y + std::abs(rows[i].z) * r.z + std::abs(rows[i].w);
        }
        r = out * (1.0f + 1e-5f);
      }
      const float k = std::abs(w.params.x);
      const std::uint32_t a = std::min<std::uint32_t>(w.meta.y, 2), b = std::min<std::uint32_t>(w.meta.z, 2);
      float j = 1.0f;
      switch (w.meta.x) {
        case L::WARP_TWIST: {
          // Rotation about axis a by k p_a: |J| <= 1 + |k| (distance from the axis).
          const std::uint32_t u = (a + 1) % 3, v = (a + 2) % 3;
          const float radial = std::sqrt(r[u] * r[u] + r[v] * r[v]);
          j = 1.0f + k * radial;
          r[u] = r[v] = radial;
          break;
        }
        case L::WARP_TAPER:  // p_b (1 + k p_a): d/dp_b = 1 + k p_a, d/dp_a = k p_b
          j = 1.0f + k * (r[a] + r[b]);
          r[b] *= 1.0f + k * r[a];
          break;
        case L::WARP_BEND: {
          const float norm = glm::length(r);
          j = 2.0f + k * norm;
          r = glm::vec3(norm + (k > 0 ? 2.0f / k : 0.0f));
          break;
        }
        case L::WARP_SHEAR:  // p_a + k p_b
          j = 1.0f + k;
          r[a] += k * r[b];
          break;
        default: break;
      }
      stretch[dst] = s * j;
      reach[dst] = r;
      continue;
    }
    if (dst >= lip.size() || (op != L::OP_PRIM && op != L::OP_SKIP && op != L::OP_ONE_MINUS &&
                              op != L::OP_POW && y >= lip.size())) {
      continue;
    }
    switch (op) {
      case L::OP_PRIM: {
        if (y >= program.primitives.size() || z >= stretch.size()) break;
        if (z == 0 && y < program.primitiveBoxes.size() && missesBox(region, program.primitiveBoxes[y])) {
          lip[dst] = 0.0f;  // exactly 0 throughout the region
          value[dst] = 0.0f;
          break;
        }
        const auto& p = program.primitives[y];
        const float m = identity(p.meta.y) ? 1.0f : matrixStretch(program.matrices[p.meta.y]);
        const bool quadric = p.meta.x == L::PRIM_QUADRIC;
        const float scale = quadric ? std::abs(p.p0.w) : 1.0f;
        lip[dst] = (quadric ? kQuadricSlope : kWyvillSlope) * scale * m * stretch[z];
        value[dst] = scale;
        break;
      }
      case L::OP_ADD:
        lip[dst] += lip[y];
        value[dst] += value[y];
        break;
      case L::OP_MAX:
      case L::OP_MIN:
        lip[dst] = std::max(lip[dst], lip[y]);
        value[dst] = std::max(value[dst], value[y]);
        break;
      case L::OP_DIFF:
        lip[dst] = std::max(lip[dst], lip[y]);
        value[dst] = std::max(value[dst], 1.0f + value[y]);
        break;
      case L::OP_SDIFF:
        lip[dst] = value[dst] * lip[y] + (1.0f + value[y]) * lip[dst];
        value[dst] = value[dst] * (1.0f + value[y]);
        break;
      case L::OP_MUL:
        lip[dst] = value[dst] * lip[y] + value[y] * lip[dst];
        value[dst] = value[dst] * value[y];
        break;
      case L::OP_ONE_MINUS:
        value[dst] = 1.0f + value[dst];
        break;
      case L::OP_POW:  // the Ricci pair; see the header
      case L::OP_SKIP:  // the skipped subtree is 0 outside its support box: continuous
      default:
        break;
    }
  }
  LipschitzBound b;
  b.lipschitz = program.code.empty() ? 0.0f : lip[0];
  b.maxValue = program.code.empty() ? 0.0f : value[0];
  return b;
}

float LipschitzGrid::largest() const {
  float l = 0.0f;
  for (float c : cells) l = std::max(l, c);
  return l;
}

LipschitzGrid lipschitzGrid(const blobtree::Program& program, const blobtree::Aabb& region,
                            std::uint32_t maxCellsPerAxis, std::uint64_t maxWork) {
  LipschitzGrid g;
  g.region = region;
  const glm::vec3 extent = region.hi - region.lo;
  const float longest = std::max({extent.x, extent.y, extent.z, 1e-30f});
  const std::uint64_t instructions = std::max<std::uint64_t>(program.code.size(), 1);
  for (std::uint32_t perAxis = std::max(maxCellsPerAxis, 1u);; --perAxis) {
    for (int a = 0; a < 3; ++a) {
      const float n = std::ceil(extent[a] / longest * float(perAxis) - 1e-3f);
      g.dims[a] = std::uint32_t(std::clamp(n, 1.0f, float(perAxis)));
    }
    if (perAxis == 1 || std::uint64_t(g.dims[0]) * g.dims[1] * g.dims[2] * instructions <= maxWork) break;
  }
  g.cells.resize(std::size_t(g.dims[0]) * g.dims[1] * g.dims[2]);
  const glm::vec3 size = extent / glm::vec3(float(g.dims[0]), float(g.dims[1]), float(g.dims[2]));
  std::size_t i = 0;
  for (std::uint32_t z = 0; z < g.dims[2]; ++z) {
    for (std::uint32_t y = 0; y < g.dims[1]; ++y) {
      for (std::uint32_t x = 0; x < g.dims[0]; ++x, ++i) {
        blobtree::Aabb cell;
        cell.lo = region.lo + size * glm::vec3(float(x), float(y), float(z));
        cell.hi = region.lo + size * glm::vec3(float(x + 1), float(y + 1), float(z + 1));
        // The last cell ends exactly at the region's face; the shader's rounding of a point
        // to its cell can be off by an ulp, so each cell's bound covers a sliver around it.
        const glm::vec3 pad = size * 1e-3f;
        cell.lo -= pad;
        cell.hi += pad;
        g.cells[i] = lipschitzBound(program, cell).lipschitz;
      }
    }
  }
  return g;
}

}  // namespace blobvk::vk
