#include "blobvk/cutting/blade.h"

#include "blobvk/cutting/vec.h"

#include <algorithm>
#include <stdexcept>

namespace blobvk::cutting {

std::vector<Triangle> sweptTriangles(const BladeKeyframe& from, const BladeKeyframe& to) {
  std::vector<Triangle> out;
  const Triangle candidates[2] = {{from.edge0, from.edge1, to.edge1}, {from.edge0, to.edge1, to.edge0}};
  double extent = 0.0;
  for (const auto& t : candidates)
    for (const auto& p : t) extent = std::max(extent, dot(p - from.edge0, p - from.edge0));
  for (const auto& t : candidates) {
    const Double3 n = cross(t[1] - t[0], t[2] - t[0]);
    if (dot(n, n) > 1e-24 * extent * extent) out.push_back(t);
  }
  return out;
}

BladeKeyframe bladeAt(const BladePath& path, double t) {
  if (path.keyframes.empty()) throw std::invalid_argument("bladeAt: empty blade path");
  const auto& k = path.keyframes;
  if (t <= k.front().time) return k.front();
  if (t >= k.back().time) return k.back();
  const auto it = std::upper_bound(k.begin(), k.end(), t, [](double v, const BladeKeyframe& f) { return v < f.time; });
  const BladeKeyframe& b = *it;
  const BladeKeyframe& a = *(it - 1);
  const double s = (t - a.time) / (b.time - a.time);
  return {t, lerp(a.edge0, b.edge0, s), lerp(a.edge1, b.edge1, s)};
}

}  // namespace blobvk::cutting
