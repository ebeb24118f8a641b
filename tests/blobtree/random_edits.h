// Random edits of a BlobTree for the edit tests (region exactness, incremental re-meshing):
// moves, rotations, parameter and colour changes, operator and warp changes, added and removed
// children, each drawn so the edited tree still compiles. Deterministic for a seed.
#pragma once

#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/tree.h"

#include <glm/gtc/quaternion.hpp>

#include <random>
#include <vector>

namespace blobvk::testing {

class RandomEdits {
 public:
  RandomEdits(std::uint64_t seed, glm::dvec3 lo, glm::dvec3 hi) : rng_(seed), lo_(lo), hi_(hi) {}

  blobtree::Edit next(const blobtree::Node& root) {
    // A random node: walk down from the root, stopping with probability 1/3 at each level.
    blobtree::NodePath path;
    const blobtree::Node* n = &root;
    while (!n->children.empty() && (path.empty() || unit() > 0.33)) {
      path.push_back(pick(n->children.size()));
      n = &n->children[path.back()];
    }
    const double scale = glm::length(hi_ - lo_);
    const double roll = unit();
    if (n->isOperator() && roll < 0.3) {
      if (roll < 0.15) {
        blobtree::AddChild add;
        add.child = randomPrimitive(scale);
        add.at = pick(n->children.size() + 1);
        return {path, add};
      }
      const auto type = std::get<blobtree::Operator>(n->kind).type;
      const std::size_t min = type == blobtree::OperatorType::Difference ||
                                      type == blobtree::OperatorType::SmoothDifference ? 2 : 1;
      if (n->children.size() > min) return {path, blobtree::RemoveChild{pick(n->children.size())}};
    }
    if (n->isOperator() && roll < 0.4) {
      blobtree::Operator o = std::get<blobtree::Operator>(n->kind);
      if (o.type == blobtree::OperatorType::Ricci) o.power = 1.0 + 3.0 * unit();
      else if (o.type == blobtree::OperatorType::Blend) o.type = blobtree::OperatorType::Union;
      else if (o.type == blobtree::OperatorType::Union) o.type = blobtree::OperatorType::Blend;
      return {path, blobtree::SetOperator{o}};
    }
    if (n->isWarp() && roll < 0.4) {
      blobtree::Warp w = std::get<blobtree::Warp>(n->kind);
      w.factor *= 0.8 + 0.4 * unit();
      return {path, blobtree::SetWarp{w}};
    }
    if (n->isPrimitive() && roll < 0.5) {
      blobtree::Primitive p = std::get<blobtree::Primitive>(n->kind);
      if (roll < 0.25) p.colour = {unit(), unit(), unit()};
      else if (roll < 0.38) p.support *= 0.8 + 0.4 * unit();
      else p.radius *= 0.8 + 0.4 * unit(), p.a += offset(0.05 * scale);
      return {path, blobtree::SetPrimitive{p}};
    }
    blobtree::Transform t = n->transform;
    t.translate += offset(0.04 * scale);
    if (unit() < 0.3) t.rotate = glm::angleAxis(0.3 * (unit() - 0.5), glm::normalize(offset(1.0) + glm::dvec3(0, 0, 1e-3))) * t.rotate;
    return {path, blobtree::SetTransform{t}};
  }

 private:
  double unit() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_); }
  std::size_t pick(std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }
  glm::dvec3 offset(double r) { return {r * (2 * unit() - 1), r * (2 * unit() - 1), r * (2 * unit() - 1)}; }

  blobtree::Node randomPrimitive(double scale) {
    blobtree::Primitive p;
    p.type = unit() < 0.7 ? blobtree::PrimitiveType::Point : blobtree::PrimitiveType::Line;
    const glm::dvec3 c = lo_ + (hi_ - lo_) * glm::dvec3(unit(), unit(), unit());
    p.a = c;
    p.b = c + offset(0.05 * scale);
    p.support = scale * (0.03 + 0.05 * unit());
    p.colour = {unit(), unit(), unit()};
    return blobtree::Node{p, "", {}, {}};
  }

  std::mt19937_64 rng_;
  glm::dvec3 lo_, hi_;
};

}  // namespace blobvk::testing
