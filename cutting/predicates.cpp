#include "blobvk/cutting/predicates.h"

#include <cfloat>
#include <cmath>

namespace blobvk::cutting {
namespace {

template <typename Real>
int filteredSign(Double3 a, Double3 b, Double3 c, Double3 d, Real epsilon) {
  const Real adx = Real(a.x) - Real(d.x), ady = Real(a.y) - Real(d.y), adz = Real(a.z) - Real(d.z);
  const Real bdx = Real(b.x) - Real(d.x), bdy = Real(b.y) - Real(d.y), bdz = Real(b.z) - Real(d.z);
  const Real cdx = Real(c.x) - Real(d.x), cdy = Real(c.y) - Real(d.y), cdz = Real(c.z) - Real(d.z);
  const Real bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const Real cdxady = cdx * ady, adxcdy = adx * cdy;
  const Real adxbdy = adx * bdy, bdxady = bdx * ady;
  const Real det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const Real permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                         (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                         (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
  // Shewchuk's o3derrboundA = (7 + 56 eps) eps; the differences a-d etc. are rounded too, so we
  // add a safety factor of 2 (the coordinates are not exact grid values).
  const Real bound = Real(2) * (Real(7) + Real(56) * epsilon) * epsilon * permanent;
  if (det > bound) return 1;
  if (-det > bound) return -1;
  return 0;
}

}  // namespace

double orient3dValue(Double3 a, Double3 b, Double3 c, Double3 d) {
  return dot(a - d, cross(b - d, c - d));
}

int orient3dSign(Double3 a, Double3 b, Double3 c, Double3 d) {
  const int fast = filteredSign<double>(a, b, c, d, DBL_EPSILON / 2);
  if (fast != 0) return fast;
  return filteredSign<long double>(a, b, c, d, LDBL_EPSILON / 2);
}

SegmentHit segmentCrossesTriangle(Double3 p, Double3 q, Double3 a, Double3 b, Double3 c) {
  return segmentCrossesTriangle(p, q, a, b, c, 0, 0);
}

SegmentHit segmentCrossesTriangle(Double3 p, Double3 q, Double3 a, Double3 b, Double3 c, int sideP, int sideQ) {
  SegmentHit result;
  const int sp = sideP != 0 ? sideP : orient3dSign(a, b, c, p);
  const int sq = sideQ != 0 ? sideQ : orient3dSign(a, b, c, q);
  if (sp == 0 || sq == 0 || sp == sq) return result;
  const int s1 = orient3dSign(p, q, a, b);
  const int s2 = orient3dSign(p, q, b, c);
  const int s3 = orient3dSign(p, q, c, a);
  const bool allNonNegative = s1 >= 0 && s2 >= 0 && s3 >= 0;
  const bool allNonPositive = s1 <= 0 && s2 <= 0 && s3 <= 0;
  if (!(allNonNegative || allNonPositive) || (s1 == 0 && s2 == 0 && s3 == 0)) return result;
  const double dp = orient3dValue(a, b, c, p);
  const double dq = orient3dValue(a, b, c, q);
  double t = dp / (dp - dq);
  if (!(t > 0.0)) t = 0.0;
  if (!(t < 1.0)) t = 1.0;
  result.hit = true;
  result.t = t;
  return result;
}

Double3 closestPointOnTriangle(Double3 p, Double3 a, Double3 b, Double3 c) {
  const Double3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Double3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Double3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace blobvk::cutting
