// The MPU polygonizer's normals from gradients (four lanes at a time) against
// blobtree::outwardNormal, bit for bit: ordinary, zero, tiny (subnormal), huge (|g| overflows),
// infinite and NaN gradients, at every count (the four-lane loop and its tail).
#include "blobvk/blobtree/gradient.h"
#include "blobvk/cpu_simd/mpu_attributes.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace blobvk::cpu {
namespace {

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

TEST(MpuAttributes, NormalsAreOutwardNormalsBitForBit) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> kind(0, 9);
  const float specials[] = {0.0f, -0.0f, 1e-40f, -3e-42f, 3e38f, -2e38f,
                            std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()};
  for (std::size_t n = 0; n < 70; ++n) {
    std::vector<float> gx(n), gy(n), gz(n);
    for (std::size_t e = 0; e < n; ++e) {
      float* g[3] = {&gx[e], &gy[e], &gz[e]};
      for (float* c : g) {
        const int k = kind(rng);
        *c = k < 8 ? u(rng) * std::pow(10.0f, float(k - 4)) : specials[std::size_t(rng() % 8)];
      }
    }
    std::vector<mesh::Float3> out(n);
    detail::outwardNormals(gx.data(), gy.data(), gz.data(), n, out.data());
    for (std::size_t e = 0; e < n; ++e) {
      const glm::vec3 ref = blobtree::outwardNormal({gx[e], gy[e], gz[e]});
      ASSERT_EQ(bits(out[e].x), bits(ref.x)) << n << " " << e << ": " << gx[e] << " " << gy[e] << " " << gz[e];
      ASSERT_EQ(bits(out[e].y), bits(ref.y)) << n << " " << e;
      ASSERT_EQ(bits(out[e].z), bits(ref.z)) << n << " " << e;
    }
  }
}

TEST(MpuAttributes, InterleaveKeepsEachChannel) {
  const std::vector<float> r = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f}, g = {1, 2, 3, 4, 5}, b = {-1, -2, -3, -4, -5};
  std::vector<mesh::Float3> out(5);
  detail::interleave(r.data(), g.data(), b.data(), 5, out.data());
  for (std::size_t e = 0; e < 5; ++e) {
    EXPECT_EQ(out[e].x, r[e]);
    EXPECT_EQ(out[e].y, g[e]);
    EXPECT_EQ(out[e].z, b[e]);
  }
}

}  // namespace
}  // namespace blobvk::cpu
