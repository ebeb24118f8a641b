// Marching-cubes case table, generated (not typed in) from one rule so that it is watertight:
// on a face whose inside corners are diagonal, the inside corners are kept apart. Neighbouring
// cells see the same face, so they cut it the same way, and every crossing edge ends up in
// exactly one closed polygon per cell: the surface is closed and edge-manifold.
//
// The rule, per face seen from outside with its corners counter-clockwise: each maximal run of
// inside corners gives one segment from the crossing before the run to the crossing after it.
// Segments chain into loops (started at their lowest edge id). Each loop is fanned from its first
// vertex whose fan diagonals never join two crossings of one face (a neighbour could fan through
// the same pair, putting four triangles on one mesh edge); such a vertex exists for every loop
// (static_assert'ed). Triangles are counter-clockwise seen from outside (the normal points away
// from the inside corners).
//
// Corner c of a cell sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). A configuration sets
// bit c when corner c is inside (field >= iso). Edge e runs along axis e / 4 from the corner whose
// two other coordinates are (e & 1, (e >> 1) & 1), in increasing axis order (for the x axis:
// y = e & 1, z = (e >> 1) & 1; for y: x, z; for z: x, y).
#pragma once

#include <array>
#include <cstdint>

namespace blobvk::mesh {

struct McCase {
  std::uint8_t triangleCount = 0;  // 0..5: the rule needs at most 5, static_assert'ed at build
  std::array<std::uint8_t, 18> edges{};  // 3 edge ids per triangle, counter-clockwise from outside
};

// The 256 cases, indexed by configuration. Built once, thread-safe.
const std::array<McCase, 256>& marchingCubesCases();

// Offset (0/1 per axis) of the start corner of edge e, and its axis.
constexpr int mcEdgeAxis(int e) { return e >> 2; }
constexpr std::array<int, 3> mcEdgeStart(int e) {
  const int axis = e >> 2, u = e & 1, v = (e >> 1) & 1;
  if (axis == 0) return {0, u, v};
  if (axis == 1) return {u, 0, v};
  return {u, v, 0};
}

// Corner ids (0..7) at the start and the end of edge e.
constexpr int mcEdgeStartCorner(int e) {
  const std::array<int, 3> s = mcEdgeStart(e);
  return s[0] | (s[1] << 1) | (s[2] << 2);
}
constexpr int mcEdgeEndCorner(int e) { return mcEdgeStartCorner(e) | (1 << mcEdgeAxis(e)); }

}  // namespace blobvk::mesh
