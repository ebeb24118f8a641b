#include "blobvk/vk/extract/scan.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace blobvk::testing {
namespace {

class ScanTest : public VulkanTest, public ::testing::WithParamInterface<std::uint32_t> {};

TEST_P(ScanTest, MatchesSequentialExclusiveScan) {
  const std::uint32_t n = GetParam();
  std::mt19937 rng(n);
  std::vector<std::uint32_t> values(n);
  for (auto& v : values) v = rng() % 4;  // like edge counts: small, many zeros
  vk::Buffer data = device().createBuffer(std::max<std::uint32_t>(n, 1) * 4);
  device().upload(data, values.data(), n * 4ull);
  vk::Buffer scratch = device().createBuffer((vk::scanScratchWords(n) + 1) * 4);
  vk::Buffer totals = device().createBuffer(16);
  const std::uint32_t sentinel = 0xdeadbeef;
  device().upload(totals, &sentinel, 4, 4);
  device().run([&](vk::Recorder& rec) {
    vk::recordExclusiveScan(rec, data.handle(), 0, n, scratch.handle(), 0, totals.handle(), 0);
    rec.hostBarrier();
  });
  std::vector<std::uint32_t> got(n);
  device().download(data, got.data(), n * 4ull);
  std::uint32_t tot[2];
  device().download(totals, tot, 8);
  std::uint32_t running = 0;
  std::size_t wrong = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (got[i] != running) ++wrong;
    running += values[i];
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(tot[0], running);
  EXPECT_EQ(tot[1], sentinel) << "scan wrote outside its total slot";
}

// 0 and 1, chunk edges (64 values per invocation: 63, 64, 65), two levels (4096 = 64 chunks),
// three (262144 = 64^3) and four levels.
INSTANTIATE_TEST_SUITE_P(TrickySizes, ScanTest,
                         ::testing::Values(0u, 1u, 7u, 63u, 64u, 65u, 1023u, 1024u, 1025u, 4095u, 4096u, 4097u,
                                           262144u, 262145u, 1048576u + 7u, 1048576u * 2u + 1025u));

}  // namespace
}  // namespace blobvk::testing
