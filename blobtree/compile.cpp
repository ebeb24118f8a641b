// compile(): BlobTree -> Program.
//
// Two passes over the tree:
//  1. lower(): fold affine transforms into one world->unit-frame matrix per primitive (and one
//     per warp, which must see its own input frame), scale skeletons by the kernel support, and
//     compute per node: a bounding box outside which the field is exactly 0 (in the coordinates
//     of the node's point register), an interval of field values, the registers it needs
//     (Sethi-Ullman, extended to n-ary accumulation) and its primitive count.
//  2. emit(): post-order code. An n-ary operator evaluates its neediest child first into its
//     own register r and every further child into r + 1, combining as it goes, so the code
//     needs max(need(c0), 1 + max need(c_i>0)) registers: 2 for a caterpillar tree, about
//     log2 N for a balanced one. A subtree with a finite box starts with OP_SKIP, which jumps
//     past it and writes 0 when the point is outside (the escape link of stackless BVH walks).
#include "blobvk/blobtree/compiled_nodes.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_limits.h"
#include "blobvk/blobtree/tree.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::blobtree {
namespace {

using Mat4 = glm::dmat4;
constexpr double kInf = 1e30;
constexpr float kInfF = std::numeric_limits<float>::infinity();
// The readers' limit: lowering recurses (~0.7 KB of stack per level), so 100000 levels
// overflowed an 8 MB stack at ~12000; 4096 levels need ~3 MB.
constexpr std::size_t kMaxDepth = limits::kMaxDepth;

struct Box {
  glm::dvec3 lo{kInf}, hi{-kInf};
  static Box everything() { return {glm::dvec3(-kInf), glm::dvec3(kInf)}; }
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  bool finite() const {
    return !empty() && std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x),
                                 std::abs(hi.y), std::abs(hi.z)}) < 1e29;
  }
  void grow(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void grow(const Box& b) {
    if (b.empty()) return;
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  Box intersect(const Box& b) const { return {glm::max(lo, b.lo), glm::min(hi, b.hi)}; }
};

// Image of a box under an affine map, from all 8 corners (the thesis mapped only 2, which is
// wrong under rotation). An unbounded box stays unbounded.
Box transformBox(const Mat4& m, const Box& b) {
  if (b.empty()) return b;
  if (!b.finite()) return Box::everything();
  Box out;
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 p{(c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y,
                       (c & 4) ? b.hi.z : b.lo.z};
    out.grow(glm::dvec3(m * glm::dvec4(p, 1.0)));
  }
  return out;
}

struct Interval {
  double lo = 0.0, hi = 0.0;
};

struct Lowered {
  enum class Kind { Primitive, Operator, Warp } kind = Kind::Primitive;
  OperatorType op = OperatorType::Blend;
  double power = 1.0;
  bool cutter = false;     // a difference's subtracted child (its field enters as 1 - f)
  bool reordered = false;  // a difference whose first child is not evaluated first
  std::uint32_t index = 0;  // primitive or warp record
  std::vector<Lowered> children;
  Box box;  // in the coordinates of the point register this node reads
  Interval range;
  std::uint32_t need = 1;
  std::uint32_t primitives = 0;
  std::uint32_t warpDepth = 0;  // deepest warp nesting at or below this node
};

Mat4 toMatrix(const Transform& t) {
  Mat4 m = glm::translate(Mat4(1.0), t.translate);
  m = m * glm::mat4_cast(glm::normalize(t.rotate));
  return glm::scale(m, t.scale);
}

// A float box holding the double box (bounds rounded outwards); everything when not finite.
layout::BoxRecord outwardBoxRecord(const Box& b) {
  if (!b.finite()) return {{-kInfF, -kInfF, -kInfF, 0.0f}, {kInfF, kInfF, kInfF, 0.0f}};
  auto down = [](double v) { return std::nextafter(float(v), -kInfF); };
  auto up = [](double v) { return std::nextafter(float(v), kInfF); };
  return {{down(b.lo.x), down(b.lo.y), down(b.lo.z), 0.0f}, {up(b.hi.x), up(b.hi.y), up(b.hi.z), 0.0f}};
}

layout::vec4 v4(const glm::dvec3& v, double w = 0.0) {
  return {float(v.x), float(v.y), float(v.z), float(w)};
}

std::uint32_t packColour(const glm::dvec3& c) {
  auto byte = [](double x) {
    return std::uint32_t(std::lround(std::clamp(x, 0.0, 1.0) * 255.0));
  };
  return byte(c.x) | (byte(c.y) << 8) | (byte(c.z) << 16) | (255u << 24);
}

// Box of a disc of radius r around centre c with unit normal n.
Box discBox(const glm::dvec3& c, const glm::dvec3& n, double r) {
  const glm::dvec3 ext = r * glm::sqrt(glm::max(glm::dvec3(1.0) - n * n, glm::dvec3(0.0)));
  return {c - ext, c + ext};
}

glm::dvec3 unitOr(const glm::dvec3& v, const glm::dvec3& fallback) {
  const double len = glm::length(v);
  return len > 0.0 ? v / len : fallback;
}

class Compiler {
 public:
  Compiler(const CompileOptions& options, std::vector<CompiledNode>* nodes)
      : options_(options), nodes_(nodes) {
    program_.matrices.push_back({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}});
  }

  Program run(const Node& root) {
    Lowered top = lower(root, Mat4(1.0), 0);
    if (top.need > layout::MAX_FIELD_REGISTERS) {
      throw std::invalid_argument("tree needs " + std::to_string(top.need) +
                                  " field registers; the evaluators have " +
                                  std::to_string(layout::MAX_FIELD_REGISTERS));
    }
    program_.fieldRegisters = top.need;
    program_.pointRegisters = top.warpDepth + 1;
    emit(top, 0, 0);
    if (top.box.empty()) {
      program_.bounds = {};
    } else {
      program_.bounds.lo = glm::vec3(top.box.lo);
      program_.bounds.hi = glm::vec3(top.box.hi);
    }
    return std::move(program_);
  }

 private:
  // Stores the world->local matrix (inverse of `forward`), or index 0 for the identity.
  std::uint32_t addMatrix(const Mat4& forward) {
    if (forward == Mat4(1.0)) return 0;
    const double det = glm::determinant(forward);
    if (!(std::abs(det) > 1e-300) || !std::isfinite(det)) {
      throw std::invalid_argument("a transform is singular (zero scale?)");
    }
    const Mat4 inv = glm::inverse(forward);
    // glm is column-major: inv[col][row].
    program_.matrices.push_back({{float(inv[0][0]), float(inv[1][0]), float(inv[2][0]), float(inv[3][0])},
                                 {float(inv[0][1]), float(inv[1][1]), float(inv[2][1]), float(inv[3][1])},
                                 {float(inv[0][2]), float(inv[1][2]), float(inv[2][2]), float(inv[3][2])}});
    return std::uint32_t(program_.matrices.size() - 1);
  }

  Lowered lower(const Node& node, const Mat4& parent, std::size_t depth) {
    if (depth > kMaxDepth) throw std::invalid_argument("tree deeper than " + std::to_string(kMaxDepth) + " levels");
    const Mat4 frame = node.transform.isIdentity() ? parent : parent * toMatrix(node.transform);
    if (!nodes_) return lowerNode(node, frame, depth);
    const std::size_t at = nodes_->size();
    nodes_->emplace_back();
    Lowered out = lowerNode(node, frame, depth);
    record(at, out);
    return out;
  }

  Lowered lowerNode(const Node& node, const Mat4& frame, std::size_t depth) {
    if (const auto* prim = std::get_if<Primitive>(&node.kind)) return lowerPrimitive(*prim, frame);
    if (const auto* warp = std::get_if<Warp>(&node.kind)) return lowerWarp(node, *warp, frame, depth);
    return lowerOperator(node, std::get<Operator>(node.kind), frame, depth);
  }

  // The node's box carried out to world space through the enclosing warps, innermost first,
  // the way lowerWarp carries its child's box.
  void record(std::size_t at, const Lowered& out) {
    Box world = out.box;
    for (auto it = warpStack_.rbegin(); it != warpStack_.rend(); ++it)
      world = transformBox(it->second, unwarpBox(*it->first, world));
    CompiledNode& n = (*nodes_)[at];
    n.lo = world.lo, n.hi = world.hi;
    if (!world.empty() && !world.finite()) n.lo = glm::dvec3(-kInf), n.hi = glm::dvec3(kInf);
    n.need = out.need;
    n.subtreeSize = std::uint32_t(nodes_->size() - at);
  }

  Lowered lowerPrimitive(const Primitive& prim, const Mat4& frame) {
    if (!(prim.support > 0.0)) throw std::invalid_argument("primitive support must be > 0");
    // Unit frame: skeleton coordinates divided by the support radius R, so the kernel sees
    // d^2 / R^2. forward maps unit frame -> point register frame.
    const double invR = 1.0 / prim.support;
    const Mat4 forward = glm::scale(frame, glm::dvec3(prim.support));
    layout::PrimitiveRecord rec{};
    rec.meta = {std::uint32_t(prim.type), addMatrix(forward), packColour(prim.colour), 0u};
    const glm::dvec3 a = prim.a * invR, b = prim.b * invR, c = prim.c * invR;
    Box local;
    switch (prim.type) {
      case PrimitiveType::Point:
        rec.p0 = v4(a);
        local.grow(a);
        break;
      case PrimitiveType::QuadricPoint:
        rec.p0 = v4(a, prim.scale);
        local.grow(a);
        break;
      case PrimitiveType::Line: {
        const glm::dvec3 ab = b - a;
        const double len2 = glm::dot(ab, ab);
        rec.p0 = v4(a);
        rec.p1 = v4(ab, len2 > 0.0 ? 1.0 / len2 : 0.0);
        local.grow(a);
        local.grow(b);
        break;
      }
      case PrimitiveType::Cylinder: {
        const glm::dvec3 n = unitOr(prim.b, {0, 1, 0});
        const double r = prim.radius * invR, h = prim.height * invR;
        rec.p0 = v4(a);
        rec.p1 = v4(n);
        rec.p2 = v4({r, h, 0.0});
        local.grow(discBox(a, n, r));
        local.grow(discBox(a + n * h, n, r));
        break;
      }
      case PrimitiveType::Disc:
      case PrimitiveType::Ring: {
        const glm::dvec3 n = unitOr(prim.b, {0, 1, 0});
        const double r = prim.radius * invR;
        rec.p0 = v4(a);
        rec.p1 = v4(n);
        rec.p2 = v4({r, 0.0, 0.0});
        local.grow(discBox(a, n, r));
        break;
      }
      case PrimitiveType::Cube:
        rec.p0 = v4(a);
        rec.p1 = v4(glm::abs(b));
        local.grow(a - glm::abs(b));
        local.grow(a + glm::abs(b));
        break;
      case PrimitiveType::Triangle:
        rec.p0 = v4(a);
        rec.p1 = v4(b);
        rec.p2 = v4(c);
        local.grow(a);
        local.grow(b);
        local.grow(c);
        break;
    }
    // Full kernel support: the field is non-zero up to distance 1 in the unit frame (the thesis
    // padded by 0.5 and so cut off long-range blending).
    local.lo -= glm::dvec3(1.0);
    local.hi += glm::dvec3(1.0);

    Lowered out;
    out.kind = Lowered::Kind::Primitive;
    out.index = std::uint32_t(program_.primitives.size());
    program_.primitives.push_back(rec);
    out.box = transformBox(forward, local);
    program_.primitiveBoxes.push_back(outwardBoxRecord(out.box));
    out.range = {0.0, prim.type == PrimitiveType::QuadricPoint ? std::max(prim.scale, 0.0) : 1.0};
    out.need = 1;
    out.primitives = 1;
    return out;
  }

  Lowered lowerWarp(const Node& node, const Warp& warp, const Mat4& frame, std::size_t depth) {
    if (node.children.size() != 1) throw std::invalid_argument("a warp needs exactly one child");
    const std::uint32_t matrix = addMatrix(frame);
    const std::uint32_t index = std::uint32_t(program_.warps.size());
    program_.warps.push_back({{std::uint32_t(warp.type), std::uint32_t(warp.axis),
                               std::uint32_t(warp.otherAxis), matrix},
                              {float(warp.factor), float(warp.centre), float(warp.lo), float(warp.hi)}});
    // The child starts a fresh frame: its point register holds the warped local point.
    if (nodes_) warpStack_.emplace_back(&warp, frame);
    Lowered child = lower(node.children.front(), Mat4(1.0), depth + 1);
    if (nodes_) warpStack_.pop_back();
    Lowered out;
    out.kind = Lowered::Kind::Warp;
    out.index = index;
    out.box = transformBox(frame, unwarpBox(warp, child.box));
    out.range = child.range;
    out.need = child.need;
    out.primitives = child.primitives;
    out.warpDepth = child.warpDepth + 1;
    if (out.warpDepth + 1 > layout::MAX_POINT_REGISTERS) {
      // Each nested warp takes a point register of the evaluators (shaders/program_layout.h).
      throw std::invalid_argument("warps nested deeper than " + std::to_string(layout::MAX_POINT_REGISTERS - 1) +
                                  ": a " + toString(warp.type) + " warp" +
                                  (node.id.empty() ? std::string() : " (id \"" + node.id + "\")") + " holds " +
                                  std::to_string(out.warpDepth - 1) + " more, one inside the other");
    }
    out.children.push_back(std::move(child));
    return out;
  }

  // The set of points p whose warp(p) lies in `b`, bounded by a box where that is simple;
  // otherwise everything (the subtree then gets no skip).
  static Box unwarpBox(const Warp& w, const Box& b) {
    if (b.empty() || !b.finite()) return b;
    Box out = b;
    const int a = w.axis, o = w.otherAxis;
    switch (w.type) {
      case WarpType::Twist: {
        const int u = (a + 1) % 3, v = (a + 2) % 3;
        const double ru = std::max(std::abs(b.lo[u]), std::abs(b.hi[u]));
        const double rv = std::max(std::abs(b.lo[v]), std::abs(b.hi[v]));
        const double r = std::sqrt(ru * ru + rv * rv);
        out.lo[u] = out.lo[v] = -r;
        out.hi[u] = out.hi[v] = r;
        return out;
      }
      case WarpType::Taper: {
        const double s0 = 1.0 + w.factor * b.lo[a], s1 = 1.0 + w.factor * b.hi[a];
        if (std::min(s0, s1) <= 1e-6) return Box::everything();
        out.lo[o] = std::min({b.lo[o] / s0, b.lo[o] / s1});
        out.hi[o] = std::max({b.hi[o] / s0, b.hi[o] / s1});
        return out;
      }
      case WarpType::Shear: {
        const double k0 = w.factor * b.lo[o], k1 = w.factor * b.hi[o];
        out.lo[a] = b.lo[a] - std::max(k0, k1);
        out.hi[a] = b.hi[a] - std::min(k0, k1);
        return out;
      }
      case WarpType::Bend:
        return Box::everything();
    }
    return Box::everything();
  }

  Lowered lowerOperator(const Node& node, const Operator& op, const Mat4& frame, std::size_t depth) {
    if (node.children.empty()) throw std::invalid_argument("an operator needs children");
    Lowered out;
    out.kind = Lowered::Kind::Operator;
    out.op = op.type;
    out.power = op.power;
    out.children.reserve(node.children.size());
    for (const Node& child : node.children) out.children.push_back(lower(child, frame, depth + 1));

    auto& ch = out.children;
    const bool difference =
        op.type == OperatorType::Difference || op.type == OperatorType::SmoothDifference;
    // Interval and box rules below read the first child as the one cut from, so they run on the
    // original order; the evaluation order is settled after them.
    for (std::size_t i = 1; difference && i < ch.size(); ++i) ch[i].cutter = true;
    for (const Lowered& c : ch) {
      out.primitives += c.primitives;
      out.warpDepth = std::max(out.warpDepth, c.warpDepth);
    }

    Box all;
    for (const Lowered& c : ch) all.grow(c.box);
    if (!std::all_of(ch.begin(), ch.end(), [](const Lowered& c) { return c.box.finite() || c.box.empty(); })) {
      all = Box::everything();
    }
    const Interval first = ch.front().range;
    switch (op.type) {
      case OperatorType::Blend: {
        Interval r{0.0, 0.0};
        for (const Lowered& c : ch) r = {r.lo + c.range.lo, r.hi + c.range.hi};
        out.range = r;
        out.box = all;
        break;
      }
      case OperatorType::Ricci: {
        double lo = 0.0, hi = 0.0;
        for (const Lowered& c : ch) {
          lo += std::pow(std::max(c.range.lo, 0.0), op.power);
          hi += std::pow(std::max(c.range.hi, 0.0), op.power);
        }
        out.range = {std::pow(lo, 1.0 / op.power), std::pow(hi, 1.0 / op.power)};
        out.box = all;
        break;
      }
      case OperatorType::Union: {
        Interval r = first;
        for (const Lowered& c : ch) r = {std::max(r.lo, c.range.lo), std::max(r.hi, c.range.hi)};
        out.range = r;
        out.box = all;
        break;
      }
      case OperatorType::Intersection: {
        Interval r = first;
        bool nonNegative = true;
        Box common = Box::everything();
        for (const Lowered& c : ch) {
          r = {std::min(r.lo, c.range.lo), std::min(r.hi, c.range.hi)};
          nonNegative = nonNegative && c.range.lo >= 0.0;
          common = common.intersect(c.box);
        }
        out.range = r;
        // Outside one child's box that child is 0 and min(...) is 0 when no child is negative.
        out.box = nonNegative ? common : all;
        break;
      }
      case OperatorType::Difference: {
        Interval r = first;
        double cutterMax = 0.0;
        for (std::size_t i = 1; i < ch.size(); ++i) {
          r = {std::min(r.lo, 1.0 - ch[i].range.hi), std::min(r.hi, 1.0 - ch[i].range.lo)};
          cutterMax = std::max(cutterMax, ch[i].range.hi);
        }
        out.range = r;
        // Outside the first child's box: min(0, 1 - f_i) is 0 only if no cutter exceeds 1.
        out.box = cutterMax <= 1.0 ? ch.front().box : all;
        break;
      }
      case OperatorType::SmoothDifference: {
        Interval r = first;
        for (std::size_t i = 1; i < ch.size(); ++i) {
          const Interval m{1.0 - ch[i].range.hi, 1.0 - ch[i].range.lo};
          const double p[4] = {r.lo * m.lo, r.lo * m.hi, r.hi * m.lo, r.hi * m.hi};
          r = {*std::min_element(p, p + 4), *std::max_element(p, p + 4)};
        }
        out.range = r;
        out.box = ch.front().box;  // first child 0 => product 0
        break;
      }
    }

    // Evaluation order: neediest child first (Sethi-Ullman). A difference may move its first
    // child only by switching to the 1 - f form (OP_ONE_MINUS on cutters, then OP_MIN/OP_MUL),
    // which is commutative.
    std::stable_sort(ch.begin() + 1, ch.end(),
                     [](const Lowered& x, const Lowered& y) { return x.need > y.need; });
    if (ch.size() > 1 && ch[1].need > ch[0].need) {
      std::stable_sort(ch.begin(), ch.end(),
                       [](const Lowered& x, const Lowered& y) { return x.need > y.need; });
      out.reordered = difference;
    }
    std::uint32_t need = ch.front().need;
    for (std::size_t i = 1; i < ch.size(); ++i) need = std::max(need, ch[i].need + 1);
    out.need = need;
    return out;
  }

  void push(std::uint32_t op, std::uint32_t dst, std::uint32_t y = 0, std::uint32_t z = 0,
            std::uint32_t w = 0) {
    program_.code.push_back({{op | (dst << 8), y, z, w}});
  }

  static std::uint32_t combineOpcode(OperatorType t) {
    switch (t) {
      case OperatorType::Blend:
      case OperatorType::Ricci:
        return layout::OP_ADD;
      case OperatorType::Union:
        return layout::OP_MAX;
      case OperatorType::Intersection:
        return layout::OP_MIN;
      case OperatorType::Difference:
        return layout::OP_DIFF;
      case OperatorType::SmoothDifference:
        return layout::OP_SDIFF;
    }
    return layout::OP_ADD;
  }

  void emit(const Lowered& node, std::uint32_t reg, std::uint32_t pointReg) {
    const bool skip = options_.boxSkips && node.kind != Lowered::Kind::Primitive &&
                      node.primitives >= options_.minSkipPrimitives && node.box.finite();
    std::size_t skipAt = 0;
    if (skip) {
      skipAt = program_.code.size();
      program_.boxes.push_back({v4(node.box.lo), v4(node.box.hi)});
      push(layout::OP_SKIP, reg, std::uint32_t(program_.boxes.size() - 1), pointReg, 0);
    }
    switch (node.kind) {
      case Lowered::Kind::Primitive:
        push(layout::OP_PRIM, reg, node.index, pointReg);
        break;
      case Lowered::Kind::Warp:
        push(layout::OP_WARP, pointReg + 1, node.index, pointReg);
        emit(node.children.front(), reg, pointReg + 1);
        break;
      case Lowered::Kind::Operator: {
        const bool ricci = node.op == OperatorType::Ricci;
        const std::uint32_t power = std::bit_cast<std::uint32_t>(float(node.power));
        const std::uint32_t root = std::bit_cast<std::uint32_t>(float(1.0 / node.power));
        std::uint32_t combine = combineOpcode(node.op);
        if (node.reordered) {
          combine = node.op == OperatorType::Difference ? layout::OP_MIN : layout::OP_MUL;
        }
        // In the reordered form each cutter is complemented where it is evaluated.
        auto child = [&](const Lowered& c, std::uint32_t r) {
          emit(c, r, pointReg);
          if (ricci) push(layout::OP_POW, r, 0, 0, power);
          if (node.reordered && c.cutter) push(layout::OP_ONE_MINUS, r);
        };
        child(node.children.front(), reg);
        for (std::size_t i = 1; i < node.children.size(); ++i) {
          child(node.children[i], reg + 1);
          push(combine, reg, reg + 1);
        }
        if (ricci) push(layout::OP_POW, reg, 0, 0, root);
        break;
      }
    }
    if (skip) program_.code[skipAt].code.w = std::uint32_t(program_.code.size());
  }

  CompileOptions options_;
  Program program_;
  std::vector<CompiledNode>* nodes_ = nullptr;  // per node in pre-order, when asked for
  std::vector<std::pair<const Warp*, Mat4>> warpStack_;  // enclosing warps and their frames
};

}  // namespace

bool Aabb::finite() const {
  return !empty() && std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x),
                               std::abs(hi.y), std::abs(hi.z)}) < 1e29f;
}

void Aabb::grow(const glm::vec3& p) {
  lo = glm::min(lo, p);
  hi = glm::max(hi, p);
}

void Aabb::grow(const Aabb& b) {
  if (b.empty()) return;
  lo = glm::min(lo, b.lo);
  hi = glm::max(hi, b.hi);
}

std::size_t Program::byteSize() const {
  return code.size() * sizeof(layout::Instruction) +
         primitives.size() * sizeof(layout::PrimitiveRecord) +
         matrices.size() * sizeof(layout::MatrixRecord) + boxes.size() * sizeof(layout::BoxRecord) +
         warps.size() * sizeof(layout::WarpRecord);
}

Program compile(const Node& root, const CompileOptions& options) {
  return Compiler(options, nullptr).run(root);
}

Program compile(const Node& root, const CompileOptions& options, std::vector<CompiledNode>& nodes) {
  nodes.clear();
  return Compiler(options, &nodes).run(root);
}

}  // namespace blobvk::blobtree
