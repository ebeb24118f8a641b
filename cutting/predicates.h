// Robust geometric predicates for the blade sweep: orientation sign with a floating-point filter
// and an extended-precision fallback, and a segment-triangle crossing test built on it.
#pragma once

#include "blobvk/cutting/vec.h"

namespace blobvk::cutting {

// Sign of det[a-d, b-d, c-d] (Shewchuk's orient3d: > 0 when d lies below the plane of a, b, c
// seen counter-clockwise from above). Evaluated in double with Shewchuk's static error bound;
// when the bound cannot certify the sign it is re-evaluated in long double (64-bit mantissa on
// x86) with the matching bound, and 0 is returned when that is still uncertain. A 0 therefore
// means "degenerate within ~1e-19 relative", which the cutter treats as "touches the surface".
int orient3dSign(Double3 a, Double3 b, Double3 c, Double3 d);

// The raw double determinant (6x the signed volume of d, a, b, c); used for interpolation only.
double orient3dValue(Double3 a, Double3 b, Double3 c, Double3 d);

struct SegmentHit {
  bool hit = false;
  double t = 0.0;  // parameter along p->q of the crossing point, in (0, 1)
};

// Does the open segment (p, q) cross the closed triangle (a, b, c)? Requires p and q strictly on
// opposite sides of the triangle's plane (a touching endpoint is a cut *node*, not a cut edge)
// and the crossing inside or on the triangle's boundary. Signs come from orient3dSign.
SegmentHit segmentCrossesTriangle(Double3 p, Double3 q, Double3 a, Double3 b, Double3 c);
// The same test for a caller that already knows orient3dSign(a, b, c, p) and/or (.., q), e.g. from
// plane distances beyond their rounding slack (a signed distance along cross(b - a, c - a) has
// the opposite sign): sideP / sideQ = that sign, or 0 when unknown (then evaluated here). Saves
// two of the five orientation tests of most calls.
SegmentHit segmentCrossesTriangle(Double3 p, Double3 q, Double3 a, Double3 b, Double3 c, int sideP, int sideQ);

// Closest point on the triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
Double3 closestPointOnTriangle(Double3 p, Double3 a, Double3 b, Double3 c);

}  // namespace blobvk::cutting
