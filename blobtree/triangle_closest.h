// Internal: the closest point of a triangle to p (Ericson, Real-Time Collision Detection 5.1.5),
// shared by the field and the gradient evaluators so both compute the same bits.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace blobvk::blobtree::detail {

template <typename T>
glm::vec<3, T> triangleClosest(glm::vec<3, T> p, glm::vec<3, T> a, glm::vec<3, T> b, glm::vec<3, T> c) {
  using V3 = glm::vec<3, T>;
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const T d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  const T zero(0);
  if (d1 <= zero && d2 <= zero) return a;
  const V3 bp = p - b;
  const T d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  const V3 cp = p - c;
  const T d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  const T vc = d1 * d4 - d3 * d2;
  const T vb = d5 * d2 - d1 * d6;
  const T va = d3 * d6 - d5 * d4;
  if (d3 >= zero && d4 <= d3) return b;
  if (d6 >= zero && d5 <= d6) return c;
  if (vc <= zero && d1 >= zero && d3 <= zero) return a + ab * (d1 / (d1 - d3));
  if (vb <= zero && d2 >= zero && d6 <= zero) return a + ac * (d2 / (d2 - d6));
  if (va <= zero && (d4 - d3) >= zero && (d5 - d6) >= zero)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const T sum = va + vb + vc;
  // A degenerate (zero-area) triangle never reaches here with sum == 0 unless p is on it.
  const T denom = sum != zero ? T(1) / sum : zero;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace blobvk::blobtree::detail
