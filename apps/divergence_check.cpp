#include "divergence_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

namespace blobvk::app {

DivergenceCheck::DivergenceCheck(const fem::Simulation& sim, std::string scene) : scene_(std::move(scene)) {
  const auto& x = sim.positions();
  if (x.empty()) return;
  double lo[3] = {x[0].x, x[0].y, x[0].z}, hi[3] = {lo[0], lo[1], lo[2]};
  for (const auto& p : x) {
    const double c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  }
  cx_ = 0.5 * (lo[0] + hi[0]), cy_ = 0.5 * (lo[1] + hi[1]), cz_ = 0.5 * (lo[2] + hi[2]);
  size_ = std::max(std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]), 1e-9);
  // Also below float range, which the frames are written in.
  limit_ = std::min(1000.0 * size_, 0.5 * double(std::numeric_limits<float>::max()));
}

void DivergenceCheck::check(const fem::Simulation& sim, int step, const std::string& advice) const {
  for (const auto& p : sim.positions()) {
    const bool finite = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    const double d = finite ? std::hypot(p.x - cx_, p.y - cy_, p.z - cz_) : 0.0;
    if (finite && d <= limit_) continue;
    char where[160];
    if (finite)
      std::snprintf(where, sizeof where, "a node %.3g from the body's rest centre, %.0f times its size", d,
                    d / size_);
    else
      std::snprintf(where, sizeof where, "a node position is not finite");
    throw std::runtime_error(scene_ + ": /simulation: the simulation diverged at step " + std::to_string(step) + " (" + where +
                             "); " + advice);
  }
}

}  // namespace blobvk::app
