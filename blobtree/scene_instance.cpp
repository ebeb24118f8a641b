#include "blobvk/blobtree/scene_instance.h"

#include "blobvk/blobtree/scene_limits.h"

#include <algorithm>
#include <cmath>

namespace blobvk::blobtree::detail {

bool isIdentityTransform(const Transform& t) {
  return t.translate == Vec3(0.0) && t.scale == Vec3(1.0) &&
         (t.rotate == Quat(1.0, 0.0, 0.0, 0.0) || t.rotate == Quat(-1.0, 0.0, 0.0, 0.0));
}

static bool isUniform(const Vec3& s) { return s.x == s.y && s.y == s.z; }
static bool isUnrotated(const Quat& q) {
  return q == Quat(1.0, 0.0, 0.0, 0.0) || q == Quat(-1.0, 0.0, 0.0, 0.0);
}

bool composeTransforms(const Transform& outer, const Transform& inner, Transform& out) {
  if (isIdentityTransform(inner)) {
    out = outer;
    return true;
  }
  if (isIdentityTransform(outer)) {
    out = inner;
    return true;
  }
  // outer(inner(p)) = t_o + R_o S_o (t_i + R_i S_i p). The linear part R_o S_o R_i S_i is a
  // rotation times a diagonal scale when S_o is uniform (it commutes with R_i) or when R_i is
  // the identity (the two diagonals multiply).
  if (!isUniform(outer.scale) && !isUnrotated(inner.rotate)) return false;
  Transform composed;
  composed.translate = outer.translate + outer.rotate * (outer.scale * inner.translate);
  composed.rotate = outer.rotate * inner.rotate;
  composed.scale = outer.scale * inner.scale;
  // Each transform is within the readers' range; their product need not be, and a scene written
  // with it (blobvk convert) would not read back: keep the two apart then.
  for (int i = 0; i < 3; ++i)
    if (!(std::abs(composed.translate[i]) <= limits::kMaxAbsValue && composed.scale[i] <= limits::kMaxAbsValue)) return false;
  out = composed;
  return true;
}

Node instantiate(const Node& original, const Transform& placement, const std::string& id) {
  Node copy = original;
  if (!id.empty()) copy.id = id;
  Transform combined;
  if (composeTransforms(placement, original.transform, combined)) {
    copy.transform = combined;
    return copy;
  }
  Node wrapper;
  wrapper.kind = Operator{OperatorType::Union, 2.0};
  wrapper.id = copy.id;
  wrapper.transform = placement;
  wrapper.children.push_back(std::move(copy));
  return wrapper;
}

SubtreeSize measure(const Node& node) {
  SubtreeSize size{1, 1, node.id.size()};
  for (const Node& child : node.children) {
    const SubtreeSize c = measure(child);
    size.nodes += c.nodes;
    size.idBytes += c.idBytes;
    size.height = std::max(size.height, c.height + 1);
  }
  return size;
}

}  // namespace blobvk::blobtree::detail
