// The flat containers behind the topology: open-addressing map (backward-shift deletion) and set, and
// pooled incidence lists, checked against std containers under random operation sequences.
#include "blobvk/cutting/flat_hash.h"
#include "blobvk/cutting/incidence_lists.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <unordered_map>
#include <unordered_set>

namespace blobvk::cutting {
namespace {

// A deliberately bad hash (few distinct homes) so probe runs are long and wrap around the end of
// the table: the backward shift must keep every key reachable.
struct ClusteringHash {
  std::uint64_t operator()(std::uint64_t k) const { return (k % 7) * 0x9E3779B97F4A7C15ull >> 3; }
};

template <typename Hash>
void randomOperationsMatchStdMap(std::uint64_t keyRange, int operations) {
  FlatHashMap<std::uint64_t, std::uint32_t, Hash> flat(~0ull);
  std::unordered_map<std::uint64_t, std::uint32_t> reference;
  std::mt19937_64 rng(7);
  for (int i = 0; i < operations; ++i) {
    const std::uint64_t key = rng() % keyRange;
    switch (rng() % 3) {
      case 0: {
        const auto [value, inserted] = flat.insert(key, std::uint32_t(i));
        const auto [it, refInserted] = reference.emplace(key, std::uint32_t(i));
        ASSERT_EQ(inserted, refInserted);
        ASSERT_EQ(*value, it->second);
        break;
      }
      case 1:
        ASSERT_EQ(flat.erase(key), reference.erase(key) == 1);
        break;
      default: {
        const std::uint32_t* value = flat.find(key);
        const auto it = reference.find(key);
        ASSERT_EQ(value != nullptr, it != reference.end());
        if (value) {
          ASSERT_EQ(*value, it->second);
        }
      }
    }
    ASSERT_EQ(flat.size(), reference.size());
  }
  std::size_t visited = 0;
  flat.forEach([&](std::uint64_t k, std::uint32_t v) {
    ++visited;
    ASSERT_EQ(reference.at(k), v);
  });
  EXPECT_EQ(visited, reference.size());
}

TEST(FlatHashMap, MatchesStdMapUnderRandomInsertEraseFind) { randomOperationsMatchStdMap<U64Hash>(5000, 200000); }

TEST(FlatHashMap, BackwardShiftKeepsClusteredKeysReachable) {
  randomOperationsMatchStdMap<ClusteringHash>(300, 50000);
}

TEST(FlatHashMap, RejectsTheEmptyKey) {
  FlatHashMap<std::uint64_t, int, U64Hash> map(~0ull);
  EXPECT_THROW(map.insert(~0ull), std::logic_error);
}

TEST(IncidenceLists, MatchVectorsUnderRandomPushRemoveWithCompaction) {
  const std::size_t nodes = 300;
  IncidenceLists lists;
  lists.layout(std::vector<std::uint32_t>(nodes, 2));
  std::vector<std::vector<std::uint32_t>> reference(nodes);
  std::mt19937 rng(3);
  for (int i = 0; i < 100000; ++i) {
    if (i % 1000 == 0) {  // nodes appended as the cutter does
      lists.addNode();
      reference.emplace_back();
    }
    const std::uint32_t node = std::uint32_t(rng() % reference.size());
    auto& ref = reference[node];
    if (rng() % 5 < 3 || ref.empty()) {
      lists.push(node, std::uint32_t(i));
      ref.push_back(std::uint32_t(i));
    } else {
      const std::uint32_t item = ref[rng() % ref.size()];
      ASSERT_TRUE(lists.remove(node, item));
      ref.erase(std::find(ref.begin(), ref.end(), item));
    }
  }
  std::size_t total = 0;
  for (std::uint32_t n = 0; n < reference.size(); ++n) {
    const auto span = lists.of(n);
    std::vector<std::uint32_t> got(span.begin(), span.end()), want = reference[n];
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    ASSERT_EQ(got, want) << "node " << n;
    total += want.size();
  }
  EXPECT_EQ(lists.totalEntries(), total);
  EXPECT_FALSE(lists.remove(0, 0xfffffff0u));
}

// The keys-only set (the cutter's per-event sets): inserts, lookups, clears and growth against
// std::unordered_set, with the clustering hash too.
template <typename Hash>
void randomSetOperationsMatchStdSet(std::uint64_t keyRange) {
  FlatHashSet<std::uint64_t, Hash> flat(~0ull, 4);
  std::unordered_set<std::uint64_t> reference;
  std::mt19937_64 rng(13);
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t key = rng() % keyRange;
    if (i % 5000 == 4999) {
      flat.clear();
      reference.clear();
    } else if (rng() % 2 == 0) {
      ASSERT_EQ(flat.insert(key), reference.insert(key).second) << "key " << key;
    } else {
      ASSERT_EQ(flat.contains(key), reference.count(key) == 1) << "key " << key;
    }
    ASSERT_EQ(flat.size(), reference.size());
  }
  std::size_t listed = 0;
  flat.forEach([&](std::uint64_t k) { listed += reference.count(k); });
  EXPECT_EQ(listed, reference.size());
  EXPECT_THROW(flat.insert(~0ull), std::logic_error);
}

TEST(FlatHashSet, RandomOperationsMatchStdSet) {
  randomSetOperationsMatchStdSet<U64Hash>(3000);
  randomSetOperationsMatchStdSet<ClusteringHash>(500);
}

}  // namespace
}  // namespace blobvk::cutting
