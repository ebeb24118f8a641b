// Trees built in code (not read from a file) can be arbitrarily deep. compile() lowers them
// recursively, so it must refuse depths whose recursion would overflow the stack: a 20000-level
// chain used to segfault (stack overflow in lowerOperator) although compile() claimed a limit
// of 100000 levels. Regression test for that crash.
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_limits.h"
#include "blobvk/blobtree/tree.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace {

using namespace blobvk::blobtree;

// A chain of single-child blends `levels` deep over one point.
Node chain(std::size_t levels) {
  Node root;
  Primitive p;
  p.support = 1.0;
  root.kind = p;
  for (std::size_t i = 0; i < levels; ++i) {
    Node op;
    op.kind = Operator{};
    op.children.push_back(std::move(root));
    root = std::move(op);
  }
  return root;
}

TEST(DeepTrees, ChainAtTheReadersLimitCompiles) {
  const Node root = chain(limits::kMaxDepth - 1);
  EXPECT_NO_THROW((void)compile(root));
}

TEST(DeepTrees, DeeperChainsAreRefusedNotCrashed) {
  for (std::size_t levels : {limits::kMaxDepth + 1, std::size_t(20000), std::size_t(150000)}) {
    const Node root = chain(levels);
    try {
      (void)compile(root);
      ADD_FAILURE() << levels << " levels compiled";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("deeper than"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
