// radixSort must order exactly as std::stable_sort by the same key (the cutter relies on the
// input order among equal keys to reproduce a sort of packed key << 32 | index integers).
#include "blobvk/cutting/radix_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace blobvk::cutting {
namespace {

TEST(RadixSort, MatchesStableSortByKey) {
  std::mt19937_64 rng(9);
  std::vector<std::uint64_t> scratch;
  for (std::uint32_t maxKey : {0u, 1u, 2047u, 2048u, 100000u, 4194303u, 0xffffffffu}) {
    for (std::size_t n : {0u, 1u, 17u, 5000u}) {
      std::vector<std::uint64_t> v(n);
      // Few distinct keys when maxKey is small: many ties, whose order must be kept.
      for (std::size_t i = 0; i < n; ++i)
        v[i] = (rng() % (std::uint64_t(maxKey) + 1)) << 32 | std::uint32_t(rng());
      auto key = [](std::uint64_t x) { return std::uint32_t(x >> 32); };
      std::vector<std::uint64_t> expected = v;
      std::stable_sort(expected.begin(), expected.end(), [&](std::uint64_t a, std::uint64_t b) { return key(a) < key(b); });
      radixSort(v, scratch, maxKey, key);
      ASSERT_EQ(v, expected) << "maxKey " << maxKey << ", n " << n;
    }
  }
}

}  // namespace
}  // namespace blobvk::cutting
