// See mpu_attributes.h. Four vertices at a time in SSE2 (every x86-64 has it): square root and
// division are correctly rounded in every lane as in the scalar code, so the normals keep the
// reference's bits, with a quarter of the scalar square roots and divisions.
#include "blobvk/cpu_simd/mpu_attributes.h"

#include <emmintrin.h>

#include <cmath>

namespace blobvk::cpu::detail {
namespace {

// Four lanes of normal components back to four Float3 (12 floats, in place order).
void storeFloat3x4(__m128 x, __m128 y, __m128 z, mesh::Float3* out) {
  alignas(16) float lx[4], ly[4], lz[4];
  _mm_store_ps(lx, x), _mm_store_ps(ly, y), _mm_store_ps(lz, z);
  for (int l = 0; l < 4; ++l) out[l] = {lx[l], ly[l], lz[l]};
}

}  // namespace

void outwardNormals(const float* gx, const float* gy, const float* gz, std::size_t n, mesh::Float3* out) {
  const __m128 sign = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
  std::size_t e = 0;
  for (; e + 4 <= n; e += 4) {
    const __m128 x = _mm_loadu_ps(gx + e), y = _mm_loadu_ps(gy + e), z = _mm_loadu_ps(gz + e);
    const __m128 len = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z)));
    const __m128 ok = _mm_cmpgt_ps(len, zero);  // false for 0 and NaN, as len > 0.0f
    // Lanes that are not ok divide too (exceptions are masked) and are replaced below.
    const __m128 nx = _mm_div_ps(_mm_xor_ps(x, sign), len), ny = _mm_div_ps(_mm_xor_ps(y, sign), len);
    const __m128 nz = _mm_div_ps(_mm_xor_ps(z, sign), len);
    storeFloat3x4(_mm_and_ps(ok, nx), _mm_and_ps(ok, ny), _mm_or_ps(_mm_and_ps(ok, nz), _mm_andnot_ps(ok, one)),
                  out + e);
  }
  for (; e < n; ++e) {
    const float x = gx[e], y = gy[e], z = gz[e];
    const float len = std::sqrt(x * x + y * y + z * z);
    out[e] = len > 0.0f ? mesh::Float3{-x / len, -y / len, -z / len} : mesh::Float3{0.0f, 0.0f, 1.0f};
  }
}

void interleave(const float* r, const float* g, const float* b, std::size_t n, mesh::Float3* out) {
  for (std::size_t e = 0; e < n; ++e) out[e] = {r[e], g[e], b[e]};
}

}  // namespace blobvk::cpu::detail
