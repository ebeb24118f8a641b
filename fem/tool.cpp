#include "blobvk/fem/tool.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::fem {
namespace {

using mesh::Double3;

std::array<double, 4> normalized(std::array<double, 4> q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (auto& c : q) c /= n;
  return q;
}

std::array<double, 9> toMatrix(const std::array<double, 4>& qIn) {
  const auto q = normalized(qIn);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

// World point -> tool-local point (R^T (p - c)).
Double3 toLocal(const Double3& p, const ToolPose& pose) {
  const double dx = p.x - pose.position.x, dy = p.y - pose.position.y, dz = p.z - pose.position.z;
  const auto& r = pose.rotation;
  return {r[0] * dx + r[3] * dy + r[6] * dz, r[1] * dx + r[4] * dy + r[7] * dz, r[2] * dx + r[5] * dy + r[8] * dz};
}

Double3 toWorldDirection(const Double3& v, const ToolPose& pose) {
  const auto& r = pose.rotation;
  return {r[0] * v.x + r[1] * v.y + r[2] * v.z, r[3] * v.x + r[4] * v.y + r[5] * v.z, r[6] * v.x + r[7] * v.y + r[8] * v.z};
}

// Signed distance to the skeleton in local coordinates and its gradient (unit). For the point
// and segment skeletons it is the plain distance; for the box it is negative inside, so nodes
// deep inside a box still get a push-out direction (the nearest face, as in the thesis probe).
double skeletonDistance(const Tool& tool, const Double3& q, Double3& grad) {
  auto finish = [&](double dx, double dy, double dz) {
    const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
    grad = d > 1e-300 ? Double3{dx / d, dy / d, dz / d} : Double3{0, 1, 0};
    return d;
  };
  switch (tool.shape) {
    case ToolShape::Sphere: return finish(q.x, q.y, q.z);
    case ToolShape::Capsule: return finish(q.x, q.y - std::clamp(q.y, -tool.halfLength, tool.halfLength), q.z);
    case ToolShape::Box: {
      const double ox = std::abs(q.x) - tool.halfExtents.x, oy = std::abs(q.y) - tool.halfExtents.y,
                   oz = std::abs(q.z) - tool.halfExtents.z;
      if (ox > 0 || oy > 0 || oz > 0) {
        const double d = finish(std::max(ox, 0.0), std::max(oy, 0.0), std::max(oz, 0.0));
        grad = {std::copysign(grad.x, q.x), std::copysign(grad.y, q.y), std::copysign(grad.z, q.z)};
        return d;
      }
      // Inside the core: nearest face.
      if (ox >= oy && ox >= oz) { grad = {std::copysign(1.0, q.x), 0, 0}; return ox; }
      if (oy >= oz) { grad = {0, std::copysign(1.0, q.y), 0}; return oy; }
      grad = {0, 0, std::copysign(1.0, q.z)};
      return oz;
    }
  }
  return 0;
}

const double kSupportScale = 1.0 / std::sqrt(1.0 - std::pow(2.0, -1.0 / 3.0));

}  // namespace

ToolPose Tool::poseAt(double t) const {
  ToolPose pose;
  if (path.empty()) return pose;
  const ToolKeyframe* a = &path.front();
  const ToolKeyframe* b = a;
  if (t >= path.back().time) {
    a = b = &path.back();
  } else if (t > path.front().time) {
    auto it = std::upper_bound(path.begin(), path.end(), t, [](double v, const ToolKeyframe& k) { return v < k.time; });
    b = &*it;
    a = &*(it - 1);
  }
  const double s = b->time > a->time ? (t - a->time) / (b->time - a->time) : 0.0;
  pose.position = {a->position.x + s * (b->position.x - a->position.x), a->position.y + s * (b->position.y - a->position.y),
                   a->position.z + s * (b->position.z - a->position.z)};
  auto qb = b->orientation;
  const double dot = a->orientation[0] * qb[0] + a->orientation[1] * qb[1] + a->orientation[2] * qb[2] + a->orientation[3] * qb[3];
  if (dot < 0) for (auto& c : qb) c = -c;  // shortest arc
  std::array<double, 4> q;
  for (int i = 0; i < 4; ++i) q[i] = a->orientation[i] + s * (qb[i] - a->orientation[i]);
  pose.rotation = toMatrix(q);
  return pose;
}

double Tool::field(const Double3& p, const ToolPose& pose) const {
  Double3 g;
  const double d = std::max(0.0, skeletonDistance(*this, toLocal(p, pose), g));
  const double R = radius * kSupportScale;
  if (d >= R) return 0.0;
  const double u = 1.0 - d * d / (R * R);
  return u * u * u;
}

ToolContact Tool::contact(const Double3& p, const ToolPose& pose) const {
  Double3 g;
  const double d = skeletonDistance(*this, toLocal(p, pose), g);
  ToolContact c;
  c.depth = radius - d;  // f >= 0.5 exactly when d <= radius (f is monotone in d)
  c.normal = toWorldDirection(g, pose);
  return c;
}

double Tool::boundingRadius() const {
  switch (shape) {
    case ToolShape::Sphere: return radius;
    case ToolShape::Capsule: return halfLength + radius;
    case ToolShape::Box:
      return std::sqrt(halfExtents.x * halfExtents.x + halfExtents.y * halfExtents.y + halfExtents.z * halfExtents.z) + radius;
  }
  return radius;
}

void validateTool(const Tool& tool, std::size_t index) {
  const std::string where = "tool " + std::to_string(index) + ": ";
  if (!(tool.radius > 0)) throw std::invalid_argument(where + "radius must be > 0");
  if (!(tool.stiffness > 0)) throw std::invalid_argument(where + "stiffness must be > 0");
  if (tool.shape == ToolShape::Capsule && !(tool.halfLength >= 0)) throw std::invalid_argument(where + "halfLength must be >= 0");
  if (tool.shape == ToolShape::Box && !(tool.halfExtents.x >= 0 && tool.halfExtents.y >= 0 && tool.halfExtents.z >= 0))
    throw std::invalid_argument(where + "halfExtents must be >= 0");
  if (tool.path.empty()) throw std::invalid_argument(where + "path needs at least one keyframe");
  for (std::size_t k = 0; k < tool.path.size(); ++k) {
    const auto& q = tool.path[k].orientation;
    if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] < 1e-12)
      throw std::invalid_argument(where + "keyframe " + std::to_string(k) + " has a zero quaternion");
    if (k > 0 && !(tool.path[k].time >= tool.path[k - 1].time))
      throw std::invalid_argument(where + "keyframes must be sorted by time");
  }
}

}  // namespace blobvk::fem
