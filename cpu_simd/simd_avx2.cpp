// AVX2 lanes (8 floats) for the shared evaluator kernel. Compiled with -mavx2 -mfma and
// -ffp-contract=off: the kernel must not fuse multiply-adds the scalar reference does not fuse.
#include "blobvk/cpu_simd/simd_kernels.h"

#include <immintrin.h>

namespace blobvk::cpu::detail {
namespace {

struct M8 {
  __m256 v;
  static M8 none() { return {_mm256_setzero_ps()}; }
  friend M8 operator&(M8 a, M8 b) { return {_mm256_and_ps(a.v, b.v)}; }
  friend M8 operator|(M8 a, M8 b) { return {_mm256_or_ps(a.v, b.v)}; }
  friend M8 operator~(M8 a) {
    return {_mm256_xor_ps(a.v, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))};
  }
};

struct F8 {
  using Mask = M8;
  static constexpr int W = 8;
  __m256 v;
  F8() = default;
  F8(__m256 x) : v(x) {}
  F8(float x) : v(_mm256_set1_ps(x)) {}
  static F8 load(const float* p) { return _mm256_load_ps(p); }
  static F8 loadu(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F8 a) { _mm256_store_ps(p, a.v); }
  static void storeu(float* p, F8 a) { _mm256_storeu_ps(p, a.v); }
  friend F8 operator+(F8 a, F8 b) { return _mm256_add_ps(a.v, b.v); }
  friend F8 operator-(F8 a, F8 b) { return _mm256_sub_ps(a.v, b.v); }
  friend F8 operator*(F8 a, F8 b) { return _mm256_mul_ps(a.v, b.v); }
  friend F8 operator/(F8 a, F8 b) { return _mm256_div_ps(a.v, b.v); }
  friend F8 operator-(F8 a) { return _mm256_xor_ps(a.v, _mm256_set1_ps(-0.0f)); }
  friend M8 operator<(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)}; }
  friend M8 operator<=(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)}; }
  friend M8 operator>(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)}; }
  friend M8 operator>=(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ)}; }
  friend M8 operator!=(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_NEQ_UQ)}; }
};

// std::max(a, b) = (a < b) ? b : a, which is maxps(b, a); std::min(a, b) = (b < a) ? b : a.
inline F8 vmax(F8 a, F8 b) { return _mm256_max_ps(b.v, a.v); }
inline F8 vmin(F8 a, F8 b) { return _mm256_min_ps(b.v, a.v); }
inline F8 vsqrt(F8 a) { return _mm256_sqrt_ps(a.v); }
inline F8 vabs(F8 a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a.v); }
inline F8 select(M8 m, F8 a, F8 b) { return _mm256_blendv_ps(b.v, a.v, m.v); }
inline bool any(M8 m) { return _mm256_movemask_ps(m.v) != 0; }
inline bool all(M8 m) { return _mm256_movemask_ps(m.v) == 0xff; }
// Bit for bit (+0 and -0 differ, a NaN equals its own bits).
inline bool sameBits(F8 a, F8 b) {
  const __m256i eq = _mm256_cmpeq_epi32(_mm256_castps_si256(a.v), _mm256_castps_si256(b.v));
  return _mm256_movemask_epi8(eq) == -1;
}

}  // namespace
}  // namespace blobvk::cpu::detail

#include "blobvk/cpu_simd/simd_kernel_impl.h"
#include "blobvk/cpu_simd/simd_gradient_impl.h"

namespace blobvk::cpu::detail {

void evaluateAvx2(const blobtree::Program& program, const float* x, const float* y, const float* z,
                  float* field, float* r, float* g, float* b, std::size_t n) {
  evaluateArrays<F8>(program, x, y, z, field, r, g, b, n);
}

void gradientAvx2(const blobtree::Program& program, const float* x, const float* y, const float* z,
                  float* const* outputs, bool colour, std::size_t n) {
  evaluateGradientArrays<F8>(program, x, y, z, outputs, colour, n);
}

}  // namespace blobvk::cpu::detail
