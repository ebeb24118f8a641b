// The scalpel: a segment (edge0, edge1) moving over time (thesis §6.2 AvatarScalpel). Between two
// blade positions it sweeps a bilinear quad, approximated by two triangles.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <vector>

namespace blobvk::cutting {

struct BladeKeyframe {
  double time = 0.0;  // seconds; keyframes must be strictly increasing
  mesh::Double3 edge0, edge1;
};

struct BladePath {
  std::vector<BladeKeyframe> keyframes;
};

using Triangle = std::array<mesh::Double3, 3>;

// Swept surface of the blade moving from `from` to `to`: the quad (from.e0, from.e1, to.e1,
// to.e0) as two triangles; degenerate triangles (area below 1e-24 of the squared extent) dropped.
std::vector<Triangle> sweptTriangles(const BladeKeyframe& from, const BladeKeyframe& to);

// Blade position at time t (linear interpolation between keyframes, clamped at the ends).
BladeKeyframe bladeAt(const BladePath& path, double t);

}  // namespace blobvk::cutting
