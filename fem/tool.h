// Rigid tools as implicit primitives moving along keyframed paths. A node touches a tool where
// the tool's field f = (1 - d^2/R^2)^3 is >= 0.5 (the BlobTree iso value), d being the distance
// to the tool's skeleton (point, segment or box). R is chosen so the iso surface lies at
// d = radius: R = radius / sqrt(1 - 2^(-1/3)) ~ 2.2018 radius.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <vector>

namespace blobvk::fem {

enum class ToolShape { Sphere, Capsule, Box };

struct ToolKeyframe {
  double time = 0;
  mesh::Double3 position;                            // world position of the tool's origin
  std::array<double, 4> orientation{1, 0, 0, 0};     // unit quaternion (w, x, y, z), local -> world
};

struct ToolPose {
  mesh::Double3 position;
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major, local -> world
};

struct ToolContact {
  double depth = 0;       // how far the point is inside the iso surface (> 0 when touching)
  mesh::Double3 normal;   // unit direction pushing the point out (= -grad f / |grad f|)
};

struct Tool {
  ToolShape shape = ToolShape::Sphere;
  double radius = 0.05;            // iso-surface offset from the skeleton (> 0)
  double halfLength = 0.1;         // capsule: segment from (0,-halfLength,0) to (0,+halfLength,0)
  mesh::Double3 halfExtents{0.05, 0.05, 0.05};  // box skeleton (rounded by radius)
  // Penalty stiffness in N/m per touching node: force = stiffness * depth * normal. It is also
  // added to the implicit system matrix (h^2 k n n^T), so large values stay stable.
  double stiffness = 1.0e4;
  std::vector<ToolKeyframe> path;  // sorted by time; position/orientation held outside the range

  // Pose at time t: linear in position, normalized-lerp in orientation between keyframes.
  ToolPose poseAt(double t) const;
  // Field value at a world point (1 on the skeleton, 0.5 on the iso surface, 0 beyond R).
  double field(const mesh::Double3& p, const ToolPose& pose) const;
  // Penetration depth and push-out normal; depth <= 0 means no contact.
  ToolContact contact(const mesh::Double3& p, const ToolPose& pose) const;
  // Radius of a sphere around the tool origin that contains the iso surface (broad phase).
  double boundingRadius() const;
};

// Throws std::invalid_argument (naming the tool) for radius <= 0, an empty path, unsorted
// keyframes, non-positive stiffness or a zero quaternion.
void validateTool(const Tool& tool, std::size_t index);

}  // namespace blobvk::fem
