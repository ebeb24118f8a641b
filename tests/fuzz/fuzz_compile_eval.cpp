// Fuzz target: compile() and the evaluators on trees decoded straight from bytes, reaching
// shapes and parameters no reader would produce (degenerate axes, huge scales, deep warps).
#include "fuzz_common.h"

#include <cstdint>
#include <cmath>
#include <stdexcept>

namespace {

struct Bytes {
  const std::uint8_t* p;
  std::size_t n;
  std::uint8_t byte() {
    if (n == 0) return 0;
    --n;
    return *p++;
  }
  double number() {  // a float from the input, finite by construction
    std::int16_t v = std::int16_t(byte() | (byte() << 8));
    return double(v) / 4096.0;
  }
  glm::dvec3 vec() { return {number(), number(), number()}; }
};

blobvk::blobtree::Node decode(Bytes& in, int depth) {
  using namespace blobvk::blobtree;
  const std::uint8_t tag = in.byte();
  Node node;
  if (depth <= 0 || tag % 3 == 0) {
    Primitive p;
    p.type = PrimitiveType(in.byte() % 8);
    p.a = in.vec();
    p.b = in.vec();
    p.c = in.vec();
    p.radius = std::abs(in.number()) + 0.01;
    p.height = std::abs(in.number()) + 0.01;
    p.support = std::abs(in.number()) + 0.05;
    p.scale = in.number();
    node.kind = p;
  } else if (tag % 3 == 1) {
    Warp w;
    w.type = WarpType(in.byte() % 4);
    w.axis = in.byte() % 3;
    w.otherAxis = in.byte() % 3;
    w.factor = in.number();
    w.centre = in.number();
    w.lo = -std::abs(in.number());
    w.hi = std::abs(in.number());
    node.kind = w;
    node.children.push_back(decode(in, depth - 1));
  } else {
    Operator o;
    o.type = OperatorType(in.byte() % 6);
    o.power = std::abs(in.number()) + 0.5;
    node.kind = o;
    const int count = 2 + in.byte() % 3;
    for (int i = 0; i < count; ++i) node.children.push_back(decode(in, depth - 1));
  }
  if (in.byte() & 1) {
    node.transform.translate = in.vec();
    node.transform.scale = glm::abs(in.vec()) + 0.1;
  }
  return node;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{data, size};
  const blobvk::blobtree::Node root = decode(in, 8);
  try {
    blobvk::fuzz::compileAndEvaluate(root);
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
