// Small double-precision vector helpers over mesh::Double3, shared by the cutting sources.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <cmath>

namespace blobvk::cutting {

using mesh::Double3;

inline Double3 operator+(Double3 a, Double3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Double3 operator-(Double3 a, Double3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Double3 operator*(Double3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(Double3 a, Double3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Double3 cross(Double3 a, Double3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Double3 a) { return std::sqrt(dot(a, a)); }
inline Double3 lerp(Double3 a, Double3 b, double t) { return a + (b - a) * t; }

// Signed volume of the tet (a, b, c, d); positive for the TetMesh orientation convention.
inline double tetVolume(Double3 a, Double3 b, Double3 c, Double3 d) {
  return dot(b - a, cross(c - a, d - a)) / 6.0;
}

}  // namespace blobvk::cutting
