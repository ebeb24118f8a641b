#include "tree_walk.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>

namespace blobvk::testing {
namespace {

using namespace blobtree;

double kernel(double dd) { return dd < 1.0 ? std::pow(1.0 - dd, 3) : 0.0; }

// Brute force: the closest point is inside the triangle (plane projection) or on an edge.
double triangleDistance2(glm::dvec3 p, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
  auto segment = [&](glm::dvec3 s, glm::dvec3 e) {
    const glm::dvec3 d = e - s;
    const double len2 = glm::dot(d, d);
    const double t = len2 > 0 ? std::clamp(glm::dot(p - s, d) / len2, 0.0, 1.0) : 0.0;
    const glm::dvec3 x = s + t * d - p;
    return glm::dot(x, x);
  };
  double best = std::min({segment(a, b), segment(b, c), segment(c, a)});
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double n2 = glm::dot(n, n);
  if (n2 > 0) {
    const glm::dvec3 q = p - n * (glm::dot(p - a, n) / n2);
    // Barycentric sign test.
    const bool inside = glm::dot(glm::cross(b - a, q - a), n) >= 0 &&
                        glm::dot(glm::cross(c - b, q - b), n) >= 0 &&
                        glm::dot(glm::cross(a - c, q - c), n) >= 0;
    if (inside) best = std::min(best, glm::dot(p - q, p - q));
  }
  return best;
}

double primitiveField(const Primitive& prim, glm::dvec3 q) {
  const double R = prim.support;
  q /= R;
  const glm::dvec3 a = prim.a / R, b = prim.b / R, c = prim.c / R;
  double dd = 0;
  switch (prim.type) {
    case PrimitiveType::Point:
      dd = glm::dot(q - a, q - a);
      break;
    case PrimitiveType::QuadricPoint: {
      dd = glm::dot(q - a, q - a);
      return dd < 1.0 ? prim.scale * (1 - dd) * (1 - dd) : 0.0;
    }
    case PrimitiveType::Line: {
      const glm::dvec3 d = b - a;
      const double len2 = glm::dot(d, d);
      const double t = len2 > 0 ? std::clamp(glm::dot(q - a, d) / len2, 0.0, 1.0) : 0.0;
      dd = glm::dot(q - (a + t * d), q - (a + t * d));
      break;
    }
    case PrimitiveType::Cylinder: {
      const glm::dvec3 n = glm::normalize(prim.b);
      const double r = prim.radius / R, h = prim.height / R;
      const double y = glm::dot(q - a, n);
      const double radial = glm::length((q - a) - y * n);
      const double x = std::max(radial - r, 0.0);
      const double yy = y < 0 ? -y : std::max(y - h, 0.0);
      dd = x * x + yy * yy;
      break;
    }
    case PrimitiveType::Disc:
    case PrimitiveType::Ring: {
      const glm::dvec3 n = glm::normalize(prim.b);
      const double r = prim.radius / R;
      const double y = glm::dot(q - a, n);
      const double radial = glm::length((q - a) - y * n);
      const double x = prim.type == PrimitiveType::Disc ? std::max(radial - r, 0.0) : radial - r;
      dd = x * x + y * y;
      break;
    }
    case PrimitiveType::Cube: {
      const glm::dvec3 e = glm::max(glm::abs(q - a) - glm::abs(b), glm::dvec3(0.0));
      dd = glm::dot(e, e);
      break;
    }
    case PrimitiveType::Triangle:
      dd = triangleDistance2(q, a, b, c);
      break;
  }
  return kernel(dd);
}

glm::dvec3 warp(const Warp& w, glm::dvec3 p) {
  const int a = w.axis, b = w.otherAxis;
  switch (w.type) {
    case WarpType::Twist: {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      const double t = w.factor * p[a];
      const double pu = p[u], pv = p[v];
      p[u] = pu * std::cos(t) - pv * std::sin(t);
      p[v] = pu * std::sin(t) + pv * std::cos(t);
      return p;
    }
    case WarpType::Taper:
      p[b] *= 1.0 + w.factor * p[a];
      return p;
    case WarpType::Shear:
      p[a] += w.factor * p[b];
      return p;
    case WarpType::Bend: {
      if (w.factor == 0) return p;
      const double k = w.factor, y = p[a], z = p[b];
      const double yc = std::clamp(y, w.lo, w.hi);
      const double t = k * (yc - w.centre);
      p[a] = -std::sin(t) * (z - 1 / k) + w.centre + std::cos(t) * (y - yc);
      p[b] = std::cos(t) * (z - 1 / k) + 1 / k + std::sin(t) * (y - yc);
      return p;
    }
  }
  return p;
}

}  // namespace

double treeWalkField(const Node& node, const glm::dvec3& pParent) {
  glm::dvec3 p = pParent;
  if (!node.transform.isIdentity()) {
    const Transform& t = node.transform;
    // Inverse of T * R * S applied to the point.
    p = glm::dvec3(glm::inverse(glm::mat4_cast(glm::normalize(t.rotate))) * glm::dvec4(p - t.translate, 1.0));
    p /= t.scale;
  }
  if (const auto* prim = std::get_if<Primitive>(&node.kind)) return primitiveField(*prim, p);
  if (const auto* w = std::get_if<Warp>(&node.kind)) return treeWalkField(node.children.front(), warp(*w, p));
  const Operator& op = std::get<Operator>(node.kind);
  std::vector<double> f;
  for (const Node& child : node.children) f.push_back(treeWalkField(child, p));
  switch (op.type) {
    case OperatorType::Blend: {
      double s = 0;
      for (double x : f) s += x;
      return s;
    }
    case OperatorType::Ricci: {
      double s = 0;
      for (double x : f) s += std::pow(std::max(x, 0.0), op.power);
      return std::pow(s, 1.0 / op.power);
    }
    case OperatorType::Union:
      return *std::max_element(f.begin(), f.end());
    case OperatorType::Intersection:
      return *std::min_element(f.begin(), f.end());
    case OperatorType::Difference: {
      double r = f[0];
      for (std::size_t i = 1; i < f.size(); ++i) r = std::min(r, 1.0 - f[i]);
      return r;
    }
    case OperatorType::SmoothDifference: {
      double r = f[0];
      for (std::size_t i = 1; i < f.size(); ++i) r *= 1.0 - f[i];
      return r;
    }
  }
  return 0;
}

}  // namespace blobvk::testing
