// Streamed mesh check (see streamed_check.h). Area and volume are summed in triangle order with
// checks.cpp's expressions, so they equal checkMesh's to the last bit.
#include "blobvk/mesh/streamed_check.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::mesh {

void StreamedMeshCheck::vertices(std::span<const Float3> positions, std::span<const Float3>,
                                 std::span<const Float3>) {
  const std::size_t before = parent_.size();
  if (before + positions.size() > 0xffffffffu) throw std::length_error("StreamedMeshCheck: more than 2^32 vertices");
  parent_.resize(before + positions.size());
  for (std::size_t i = before; i < parent_.size(); ++i) parent_[i] = std::uint32_t(i);
  referenced_.resize(parent_.size(), false);
  report_.vertices = parent_.size();
}

std::uint32_t StreamedMeshCheck::find(std::uint32_t x) {
  while (parent_[x] != x) {
    parent_[x] = parent_[parent_[x]];  // path halving
    x = parent_[x];
  }
  return x;
}

void StreamedMeshCheck::triangles(std::span<const std::array<std::uint32_t, 3>> triangles,
                                  const VertexWindow& window) {
  for (const auto& tri : triangles) {
    for (std::uint32_t v : tri) {
      if (v >= parent_.size() || v < window.first)
        throw std::out_of_range("StreamedMeshCheck: triangle " + std::to_string(report_.triangles) + " uses vertex " +
                                std::to_string(v) + " outside its window");
      referenced_[v] = true;
    }
    const Float3 &p0 = window[tri[0]], &p1 = window[tri[1]], &p2 = window[tri[2]];
    const double ax = double(p1.x) - p0.x, ay = double(p1.y) - p0.y, az = double(p1.z) - p0.z;
    const double bx = double(p2.x) - p0.x, by = double(p2.y) - p0.y, bz = double(p2.z) - p0.z;
    const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    report_.area += 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
    report_.volume += (double(p0.x) * (double(p1.y) * p2.z - double(p1.z) * p2.y) +
                       double(p0.y) * (double(p1.z) * p2.x - double(p1.x) * p2.z) +
                       double(p0.z) * (double(p1.x) * p2.y - double(p1.y) * p2.x)) /
                      6.0;
    ++report_.triangles;
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      ++report_.degenerateTriangles;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = tri[std::size_t(k)], b = tri[std::size_t((k + 1) % 3)];
      const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
      open_.push_back({(lo << 32) | hi, a < b});
      if (k == 2) break;  // two edges already join the triangle's three vertices
      const std::uint32_t ra = find(a), rb = find(b);
      if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  // Later runs use only vertices from the end of this window's first piece on.
  settle(window.first + window.a.size());
}

void StreamedMeshCheck::judge(std::size_t uses, bool sameDirection) {
  ++report_.edges;
  if (uses == 1) ++report_.boundaryEdges;
  if (uses >= 3) ++report_.nonManifoldEdges;
  if (uses == 2 && sameDirection) ++report_.misorientedEdges;
}

// The uses of an edge are found by a counting sort of the half-edges by lower vertex, then a
// small sort inside each vertex's bucket (a handful: twice its edges to higher vertices) of
// 8-byte (higher vertex, direction) words. Linear in the run, where one sort of all its
// half-edges made the check cost about as much as the polygonization.
void StreamedMeshCheck::settle(std::uint64_t limit) {
  if (open_.empty()) return;
  std::uint64_t first = ~std::uint64_t(0), last = 0;
  for (const HalfEdge& e : open_) first = std::min(first, e.key >> 32), last = std::max(last, e.key >> 32);
  const std::uint64_t span = last - first + 1;
  std::size_t kept = 0;
  if (span > 4 * open_.size() + 4096) {  // lower vertices spread thin: one plain sort is cheaper
    std::sort(open_.begin(), open_.end());
    for (std::size_t i = 0; i < open_.size();) {
      std::size_t j = i + 1;
      while (j < open_.size() && open_[j].key == open_[i].key) ++j;
      if ((open_[i].key >> 32) >= limit)
        for (std::size_t k = i; k < j; ++k) open_[kept++] = open_[k];
      else
        judge(j - i, j - i == 2 && open_[i].forward == open_[i + 1].forward);
      i = j;
    }
    open_.resize(kept);
    return;
  }
  bucketEnd_.assign(span + 1, 0);
  for (const HalfEdge& e : open_) ++bucketEnd_[(e.key >> 32) - first + 1];
  for (std::size_t b = 1; b <= span; ++b) bucketEnd_[b] += bucketEnd_[b - 1];
  byLower_.resize(open_.size());
  for (const HalfEdge& e : open_)
    byLower_[bucketEnd_[(e.key >> 32) - first]++] = ((e.key & 0xffffffffu) << 1) | std::uint64_t(e.forward);
  // bucketEnd_[b] is now where bucket b ends. open_ was read whole: it takes the kept edges.
  std::size_t begin = 0;
  for (std::uint64_t b = 0; b < span; ++b) {
    const std::size_t end = bucketEnd_[b];
    const std::uint64_t lo = first + b;
    if (end - begin > 1) std::sort(byLower_.begin() + std::ptrdiff_t(begin), byLower_.begin() + std::ptrdiff_t(end));
    for (std::size_t i = begin; i < end;) {
      std::size_t j = i + 1;
      while (j < end && (byLower_[j] >> 1) == (byLower_[i] >> 1)) ++j;
      if (lo >= limit)
        for (std::size_t k = i; k < j; ++k) open_[kept++] = {(lo << 32) | (byLower_[k] >> 1), (byLower_[k] & 1) != 0};
      else
        judge(j - i, j - i == 2 && (byLower_[i] & 1) == (byLower_[i + 1] & 1));
      i = j;
    }
    begin = end;
  }
  open_.resize(kept);
}

MeshReport StreamedMeshCheck::finish() {
  settle(~std::uint64_t(0));
  MeshReport r = report_;
  r.unreferencedVertices = std::size_t(std::count(referenced_.begin(), referenced_.end(), false));
  r.components = 0;
  for (std::size_t v = 0; v < parent_.size(); ++v)
    if (referenced_[v] && find(std::uint32_t(v)) == v) ++r.components;
  r.eulerCharacteristic = (long long)(r.vertices - r.unreferencedVertices) - (long long)r.edges +
                          (long long)(r.triangles - r.degenerateTriangles);
  return r;
}

}  // namespace blobvk::mesh
