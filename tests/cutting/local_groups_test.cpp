// LocalGroups names every group by its smallest member, whichever representation it uses (bit
// masks up to 64 items, union-find beyond): checked against a plain flood fill on random graphs.
#include "blobvk/cutting/local_groups.h"

#include <gtest/gtest.h>

#include <random>
#include <utility>
#include <vector>

namespace blobvk::cutting {
namespace {

std::vector<std::uint32_t> floodFillRoots(std::size_t n, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links) {
  std::vector<std::vector<std::uint32_t>> next(n);
  for (const auto& [a, b] : links) next[a].push_back(b), next[b].push_back(a);
  std::vector<std::uint32_t> root(n, ~0u);
  for (std::uint32_t start = 0; start < n; ++start) {
    if (root[start] != ~0u) continue;
    std::vector<std::uint32_t> stack{start};
    root[start] = start;
    while (!stack.empty()) {
      const std::uint32_t x = stack.back();
      stack.pop_back();
      for (std::uint32_t y : next[x])
        if (root[y] == ~0u) root[y] = start, stack.push_back(y);
    }
  }
  return root;
}

TEST(LocalGroups, NamesEachGroupByItsSmallestMember) {
  std::mt19937 rng(3);
  LocalGroups groups;  // reused across sizes, as the cutter reuses it across vertices
  std::vector<std::uint32_t> roots;
  int multiGroup = 0;
  for (std::size_t n : {1, 2, 5, 31, 63, 64, 65, 100, 64, 7}) {
    for (int round = 0; round < 20; ++round) {
      std::uniform_int_distribution<std::uint32_t> item(0, std::uint32_t(n - 1));
      std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
      const std::size_t count = std::size_t(rng() % (n + 1));  // sparse: several groups
      for (std::size_t k = 0; k < count; ++k) links.emplace_back(item(rng), item(rng));
      groups.reset(n);
      for (const auto& [a, b] : links) groups.link(a, b);
      groups.roots(roots);
      const auto expected = floodFillRoots(n, links);
      ASSERT_EQ(roots, expected) << "n = " << n << ", round " << round;
      for (std::size_t i = 0; i < n; ++i) multiGroup += expected[i] != 0;
    }
  }
  EXPECT_GT(multiGroup, 100);  // the graphs did fall apart into several groups
}

}  // namespace
}  // namespace blobvk::cutting
