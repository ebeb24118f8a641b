#include "random_strokes.h"

#include <cmath>

namespace blobvk::cutting::test {
namespace {

using mesh::Double3;

Double3 unit(Double3 v) {
  const double l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / l, v.y / l, v.z / l};
}
Double3 cross3(Double3 a, Double3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Double3 along(Double3 p, Double3 d, double s) { return {p.x + s * d.x, p.y + s * d.y, p.z + s * d.z}; }

}  // namespace

StrokeEvents RandomStrokes::next() {
  std::uniform_real_distribution<double> g(-1.0, 1.0), centre(-0.5, 0.5), half(0.25, 0.6), travel(0.3, 0.8);
  const Double3 c{centre(rng_), centre(rng_), centre(rng_)};
  const Double3 v = unit({g(rng_), g(rng_), g(rng_)});
  const Double3 u = unit(cross3(v, unit({g(rng_), g(rng_), g(rng_)})));
  const Double3 turn = unit({g(rng_), g(rng_), g(rng_)});
  const double h = half(rng_), length = travel(rng_);
  StrokeEvents events;
  std::vector<Triangle> all, previous;
  BladeKeyframe last{0.0, along(c, v, -h), along(c, v, h)};
  for (int step = 1; step <= 3; ++step) {
    const Double3 at = along(c, u, length * step / 3.0);
    const Double3 tip = along(along(at, v, h), turn, 0.1 * step);
    const BladeKeyframe now{double(step), along(at, v, -h), tip};
    std::vector<Triangle> swept = sweptTriangles(last, now);
    last = now;
    std::vector<Triangle> event = swept;
    event.insert(event.end(), previous.begin(), previous.end());
    all.insert(all.end(), swept.begin(), swept.end());
    previous = swept;
    events.push_back(std::move(event));
  }
  events.push_back(std::move(all));
  return events;
}

}  // namespace blobvk::cutting::test
