// The read-back's parallel append (vk/extract/host_copy.h) against std::vector::insert: the same
// elements in the same order, whether the vector grows, has room already, or the copy is below
// the threshold where it stays on one thread.
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/extract/host_copy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace blobvk::testing {
namespace {

template <class T>
std::vector<T> randomValues(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<T> v(n);
  auto* words = reinterpret_cast<std::uint32_t*>(v.data());
  for (std::size_t i = 0; i < n * sizeof(T) / 4; ++i) words[i] = rng();
  return v;
}

TEST(HostCopy, AppendsLikeInsertWhateverTheSizesAndCapacity) {
  using Tri = std::array<std::uint32_t, 3>;
  // Sizes below, at and far above kParallelCopyBytes (12 bytes per element), and ones that are
  // not a multiple of the copy's chunks.
  const std::size_t threshold = vk::kParallelCopyBytes / sizeof(Tri);
  const std::size_t sizes[] = {0, 7, threshold - 1, threshold, 3 * threshold + 12345, 1, 2 * threshold + 1};
  std::vector<Tri> expected, actual;
  std::uint32_t seed = 1;
  for (std::size_t n : sizes) {
    const std::vector<Tri> batch = randomValues<Tri>(n, seed++);
    expected.insert(expected.end(), batch.begin(), batch.end());
    vk::appendParallel(actual, batch.data(), n);
    ASSERT_EQ(actual.size(), expected.size());
    ASSERT_TRUE(actual == expected) << "after appending " << n;
  }
  // Room already there: no reallocation, the same bytes.
  std::vector<mesh::Float3> roomy;
  roomy.reserve(4 * threshold);
  const auto* before = roomy.data();
  const std::vector<mesh::Float3> points = randomValues<mesh::Float3>(3 * threshold, 99);
  vk::appendParallel(roomy, points.data(), points.size());
  EXPECT_EQ(roomy.data(), before);
  // Bytes, not floats: random bit patterns include NaNs, which never compare equal.
  ASSERT_EQ(roomy.size(), points.size());
  EXPECT_EQ(std::memcmp(roomy.data(), points.data(), points.size() * sizeof(mesh::Float3)), 0);
}

// growParallel with room for later appends: where the vector moves it takes that room (the next
// growth within it keeps its place), keeps what it held, and the new elements are zero.
TEST(HostCopy, GrowingWithRoomForLaterAppendsMovesOnce) {
  const std::size_t threshold = vk::kParallelCopyBytes / sizeof(std::uint64_t);
  const std::vector<std::uint64_t> first = randomValues<std::uint64_t>(2 * threshold, 5);
  std::vector<std::uint64_t> v;
  vk::appendParallel(v, first.data(), first.size());
  std::uint64_t* at = vk::growParallel(v, threshold + 3, 10 * threshold);
  EXPECT_GE(v.capacity(), 10 * threshold);
  EXPECT_EQ(at, v.data() + first.size());
  EXPECT_TRUE(std::equal(first.begin(), first.end(), v.begin()));
  EXPECT_TRUE(std::all_of(v.begin() + first.size(), v.end(), [](std::uint64_t x) { return x == 0; }));
  const auto* placed = v.data();
  vk::growParallel(v, 4 * threshold, 10 * threshold);
  EXPECT_EQ(v.data(), placed) << "the room was there";
  EXPECT_EQ(v.size(), 7 * threshold + 3);
  // Room that cannot be had (past max_size) is a wish: the vector still grows as it must.
  const std::size_t size = v.size();
  vk::growParallel(v, 4 * threshold, std::numeric_limits<std::size_t>::max());
  EXPECT_EQ(v.size(), size + 4 * threshold);
  EXPECT_TRUE(std::equal(first.begin(), first.end(), v.begin()));
}

}  // namespace
}  // namespace blobvk::testing
