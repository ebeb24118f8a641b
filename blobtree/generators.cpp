#include "blobvk/blobtree/generators.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace blobvk::blobtree {
namespace {

Node primitiveNode(const Primitive& p, const Transform& t = {}) {
  Node n;
  n.kind = p;
  n.transform = t;
  return n;
}

Node operatorNode(OperatorType type, std::vector<Node> children, std::string id = {}) {
  Node n;
  n.kind = Operator{type, 2.0};
  n.children = std::move(children);
  n.id = std::move(id);
  return n;
}

const Vec3 kStone{0.85, 0.80, 0.70};
const Vec3 kCapital{0.92, 0.86, 0.62};
const Vec3 kCeiling{0.70, 0.32, 0.26};
constexpr double kIsoDistance = 0.45420206;  // sqrt(1 - 0.5^(1/3)): skeleton to surface, R = 1

// Base disc, column and capital, standing on the origin along +y.
Node pillar(double height) {
  Primitive base;
  base.type = PrimitiveType::Disc;
  base.b = Vec3(0.0, 1.0, 0.0);
  base.radius = 1.0;
  base.colour = kStone;

  Primitive column;
  column.type = PrimitiveType::Cylinder;
  column.b = Vec3(0.0, 1.0, 0.0);
  column.radius = 0.25;
  column.height = 0.7 * height;
  column.colour = kStone;

  // The thesis scales the capital by 0.5H; flattened here so it reads as a capital on top of
  // the column (0.2H wide, 0.1H tall in the kernel's unit frame) rather than a ball around it.
  Primitive capital;
  capital.colour = kCapital;
  Transform capitalAt;
  capitalAt.translate = Vec3(0.0, 0.7 * height, 0.0);
  capitalAt.scale = Vec3(0.2 * height, 0.1 * height, 0.2 * height);

  std::vector<Node> baseAndColumn;
  baseAndColumn.push_back(primitiveNode(base));
  baseAndColumn.push_back(primitiveNode(column));
  std::vector<Node> parts;
  parts.push_back(operatorNode(OperatorType::Union, std::move(baseAndColumn)));
  parts.push_back(primitiveNode(capital, capitalAt));
  return operatorNode(OperatorType::Union, std::move(parts));
}

Node level(int index, int pillars, double radius, double height) {
  std::vector<Node> parts;
  for (int i = 0; i < pillars; ++i) {
    const double angle = 2.0 * std::numbers::pi * i / pillars;
    Node p = pillar(height);
    p.transform.translate = Vec3(radius * std::cos(angle), 0.0, radius * std::sin(angle));
    parts.push_back(std::move(p));
  }
  // The ceiling spans the top of the columns (0.7H) to the next level's floor (1.1H), so the
  // union is one connected solid: a disc flattened along y to that thickness.
  Primitive ceiling;
  ceiling.type = PrimitiveType::Disc;
  ceiling.b = Vec3(0.0, 1.0, 0.0);
  ceiling.radius = 1.2 * radius;
  ceiling.colour = kCeiling;
  Transform ceilingAt;
  ceilingAt.translate = Vec3(0.0, 0.9 * height, 0.0);
  ceilingAt.scale = Vec3(1.0, 0.2 * height / kIsoDistance, 1.0);
  parts.push_back(primitiveNode(ceiling, ceilingAt));

  Node n = operatorNode(OperatorType::Union, std::move(parts), "level" + std::to_string(index));
  n.transform.translate = Vec3(0.0, 1.1 * height * index, 0.0);
  return n;
}

}  // namespace

Node generateTower(int levels, int pillars, double radius, double height, int grid) {
  if (levels < 1 || pillars < 1 || grid < 1 || !(radius > 0.0) || !(height > 0.0))
    throw std::invalid_argument("generateTower: levels, pillars and grid must be >= 1, radius and height > 0");
  std::vector<Node> levelNodes;
  for (int k = 0; k < levels; ++k) levelNodes.push_back(level(k, pillars, radius, height));
  Node tower = operatorNode(OperatorType::Union, std::move(levelNodes), "tower");
  if (grid == 1) return tower;

  std::vector<Node> towers;
  for (int i = 0; i < grid; ++i) {
    for (int j = 0; j < grid; ++j) {
      Node copy = tower;
      copy.transform.translate = Vec3(3.0 * radius * i, 0.0, 3.0 * radius * j);
      towers.push_back(std::move(copy));
    }
  }
  return operatorNode(OperatorType::Union, std::move(towers), "towers");
}

Node generateEggshell() {
  Primitive outer;
  outer.colour = Vec3(0.93, 0.88, 0.78);
  Primitive inner;
  inner.colour = Vec3(0.95, 0.75, 0.35);
  Transform outerScale, innerScale;
  outerScale.scale = Vec3(3.45, 2.18, 3.11);
  innerScale.scale = Vec3(3.14, 1.76, 2.83);
  std::vector<Node> parts;
  parts.push_back(primitiveNode(outer, outerScale));
  parts.back().id = "outer";
  parts.push_back(primitiveNode(inner, innerScale));
  parts.back().id = "inner";
  return operatorNode(OperatorType::Difference, std::move(parts), "eggshell");
}

Node generateRandomBlobs(int n, std::uint64_t seed) {
  if (n < 1) throw std::invalid_argument("generateRandomBlobs: n must be >= 1");
  SplitMix64 rng(seed);
  // About 0.3 points per unit volume: neighbours overlap enough to blend into lumpy clusters.
  const double half = 0.75 * std::cbrt(double(n));
  std::vector<Node> points;
  points.reserve(std::size_t(n));
  for (int i = 0; i < n; ++i) {
    Primitive p;
    // Separate statements fix the order of the draws (argument evaluation order is unspecified).
    const double x = rng.uniform(-half, half);
    const double y = rng.uniform(-half, half);
    const double z = rng.uniform(-half, half);
    p.a = Vec3(x, y, z);
    p.support = rng.uniform(0.8, 1.4);
    const double r = rng.uniform(0.2, 1.0);
    const double g = rng.uniform(0.2, 1.0);
    const double b = rng.uniform(0.2, 1.0);
    p.colour = Vec3(r, g, b);
    points.push_back(primitiveNode(p));
  }
  return operatorNode(OperatorType::Blend, std::move(points), "blobs");
}

Node generateRandomRicciBlobs(int n, std::uint64_t seed, double power) {
  if (!(power > 0.0)) throw std::invalid_argument("generateRandomRicciBlobs: power must be > 0");
  Node root = generateRandomBlobs(n, seed);
  std::get<Operator>(root.kind) = Operator{OperatorType::Ricci, power};
  return root;
}

}  // namespace blobvk::blobtree
