#include "blobvk/surgery/material_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace blobvk::surgery {
namespace {

using mesh::Double3;

Double3 sub(const Double3& a, const Double3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }

}  // namespace

MaterialMap::MaterialMap(const mesh::TetMesh& mesh, const std::vector<Double3>& positions, const Box& region, double cell)
    : mesh_(mesh), positions_(positions), lo_(region.lo), cell_(std::max(cell, 1e-12)) {
  // At most ~4M cells (a blade much longer than the tets coarsens the index, not the answer).
  for (;; cell_ *= 2) {
    for (int a = 0; a < 3; ++a) {
      const double extent = a == 0 ? region.hi.x - region.lo.x : a == 1 ? region.hi.y - region.lo.y : region.hi.z - region.lo.z;
      dims_[std::size_t(a)] = std::clamp(int(std::floor(std::max(extent, 0.0) / cell_)) + 1, 1, 1 << 20);
    }
    if (double(dims_[0]) * dims_[1] * dims_[2] <= double(1 << 22)) break;
  }
  Double3 displacementSum;
  std::size_t displaced = 0;
  std::vector<std::array<int, 6>> ranges;  // cells each indexed tet's box covers: x, y, z ranges
  for (std::uint32_t t = 0; t < mesh.tets.size(); ++t) {
    const auto& n = mesh.tets[t];
    Double3 lo = positions[n[0]], hi = lo;
    for (int k = 1; k < 4; ++k) {
      const Double3& p = positions[n[std::size_t(k)]];
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    if (hi.x < region.lo.x || hi.y < region.lo.y || hi.z < region.lo.z || lo.x > region.hi.x || lo.y > region.hi.y ||
        lo.z > region.hi.z)
      continue;
    // Barycentric map of the deformed tet: l = D^-1 (p - x0), D = [x1-x0, x2-x0, x3-x0].
    const Double3 x0 = positions[n[0]], u = sub(positions[n[1]], x0), v = sub(positions[n[2]], x0), w = sub(positions[n[3]], x0);
    const double det = u.x * (v.y * w.z - v.z * w.y) - v.x * (u.y * w.z - u.z * w.y) + w.x * (u.y * v.z - u.z * v.y);
    if (!(std::abs(det) > 1e-300)) continue;  // collapsed: maps nothing
    const double s = 1.0 / det;
    Entry e{t,
            {(v.y * w.z - v.z * w.y) * s, (v.z * w.x - v.x * w.z) * s, (v.x * w.y - v.y * w.x) * s,
             (w.y * u.z - w.z * u.y) * s, (w.z * u.x - w.x * u.z) * s, (w.x * u.y - w.y * u.x) * s,
             (u.y * v.z - u.z * v.y) * s, (u.z * v.x - u.x * v.z) * s, (u.x * v.y - u.y * v.x) * s, x0.x, x0.y, x0.z}};
    tets_.push_back(e);
    auto cellOf = [&](double x, double lo0, int dim) { return std::clamp(int(std::floor((x - lo0) / cell_)), 0, dim - 1); };
    ranges.push_back({cellOf(lo.x, lo_.x, dims_[0]), cellOf(hi.x, lo_.x, dims_[0]), cellOf(lo.y, lo_.y, dims_[1]),
                      cellOf(hi.y, lo_.y, dims_[1]), cellOf(lo.z, lo_.z, dims_[2]), cellOf(hi.z, lo_.z, dims_[2])});
    for (std::uint32_t node : n) {
      const Double3 d = sub(positions[node], mesh.restPositions[node]);
      displacementSum = {displacementSum.x + d.x, displacementSum.y + d.y, displacementSum.z + d.z};
      ++displaced;
    }
  }
  // Cell lists in one array (counting sort by cell): a few thousand tets over a few hundred
  // cells, rebuilt every step the blade cuts.
  cellStart_.assign(std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]) + 1, 0);
  auto forCells = [&](const std::array<int, 6>& r, auto&& f) {
    for (int z = r[4]; z <= r[5]; ++z)
      for (int y = r[2]; y <= r[3]; ++y)
        for (int x = r[0]; x <= r[1]; ++x) f(std::size_t(key(x, y, z)));
  };
  for (const auto& r : ranges) forCells(r, [&](std::size_t c) { ++cellStart_[c + 1]; });
  for (std::size_t c = 1; c < cellStart_.size(); ++c) cellStart_[c] += cellStart_[c - 1];
  cellTets_.resize(cellStart_.back());
  std::vector<std::uint32_t> fill(cellStart_.begin(), cellStart_.end() - 1);
  for (std::uint32_t i = 0; i < ranges.size(); ++i) forCells(ranges[i], [&](std::size_t c) { cellTets_[fill[c]++] = i; });
  if (displaced) meanDisplacement_ = {displacementSum.x / double(displaced), displacementSum.y / double(displaced), displacementSum.z / double(displaced)};
}

Double3 MaterialMap::toMaterial(const Double3& p) const {
  const int cx = int(std::floor((p.x - lo_.x) / cell_)), cy = int(std::floor((p.y - lo_.y) / cell_)),
            cz = int(std::floor((p.z - lo_.z) / cell_));
  std::array<double, 4> best{};
  double bestScore = -std::numeric_limits<double>::infinity();
  const Entry* bestEntry = nullptr;
  // Rings of cells around p: the first containing tet ends the search; otherwise the tet whose
  // smallest barycentric coordinate is largest (the one p is least outside of).
  for (int r = 0; r <= 2 && bestScore < -1e-12; ++r) {
    for (int z = cz - r; z <= cz + r; ++z)
      for (int y = cy - r; y <= cy + r; ++y)
        for (int x = cx - r; x <= cx + r; ++x) {
          if (std::max({std::abs(x - cx), std::abs(y - cy), std::abs(z - cz)}) != r) continue;
          if (x < 0 || y < 0 || z < 0 || x >= dims_[0] || y >= dims_[1] || z >= dims_[2]) continue;
          const std::size_t c = std::size_t(key(x, y, z));
          for (std::uint32_t k = cellStart_[c]; k < cellStart_[c + 1]; ++k) {
            const std::uint32_t index = cellTets_[k];
            const Entry& e = tets_[index];
            const auto& m = e.inverse;
            const Double3 d{p.x - m[9], p.y - m[10], p.z - m[11]};
            const double l1 = m[0] * d.x + m[1] * d.y + m[2] * d.z, l2 = m[3] * d.x + m[4] * d.y + m[5] * d.z,
                         l3 = m[6] * d.x + m[7] * d.y + m[8] * d.z;
            const std::array<double, 4> w{1 - l1 - l2 - l3, l1, l2, l3};
            const double score = std::min({w[0], w[1], w[2], w[3]});
            // Ties (p on a shared face) go to the lower tet index: the same answer whatever the
            // order of the bins.
            if (score > bestScore || (score == bestScore && bestEntry && e.tet < bestEntry->tet)) {
              bestScore = score;
              best = w;
              bestEntry = &e;
            }
          }
        }
  }
  if (!bestEntry) return {p.x - meanDisplacement_.x, p.y - meanDisplacement_.y, p.z - meanDisplacement_.z};
  const auto& n = mesh_.tets[bestEntry->tet];
  if (bestScore >= -1e-12) {
    Double3 X;
    for (int k = 0; k < 4; ++k) {
      const Double3& r = mesh_.restPositions[n[std::size_t(k)]];
      X = {X.x + best[std::size_t(k)] * r.x, X.y + best[std::size_t(k)] * r.y, X.z + best[std::size_t(k)] * r.z};
    }
    return X;
  }
  // Outside: clamp the weights onto the tet (a point of its boundary near p), map that point,
  // and carry p's offset from it over unchanged.
  double sum = 0;
  for (double& w : best) sum += (w = std::max(w, 0.0));
  Double3 q, Q;
  for (int k = 0; k < 4; ++k) {
    const double w = best[std::size_t(k)] / sum;
    const Double3 &x = positions_[n[std::size_t(k)]], &r = mesh_.restPositions[n[std::size_t(k)]];
    q = {q.x + w * x.x, q.y + w * x.y, q.z + w * x.z};
    Q = {Q.x + w * r.x, Q.y + w * r.y, Q.z + w * r.z};
  }
  return {Q.x + p.x - q.x, Q.y + p.y - q.y, Q.z + p.z - q.z};
}

}  // namespace blobvk::surgery
