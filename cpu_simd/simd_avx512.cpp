// AVX-512 lanes (16 floats) for the shared evaluator kernel. Compiled with -mavx512f -mavx512dq
// and -ffp-contract=off (see simd_avx2.cpp).
#include "blobvk/cpu_simd/simd_kernels.h"

#include <immintrin.h>

namespace blobvk::cpu::detail {
namespace {

struct M16 {
  __mmask16 v;
  static M16 none() { return {0}; }
  friend M16 operator&(M16 a, M16 b) { return {__mmask16(a.v & b.v)}; }
  friend M16 operator|(M16 a, M16 b) { return {__mmask16(a.v | b.v)}; }
  friend M16 operator~(M16 a) { return {__mmask16(~a.v)}; }
};

struct F16 {
  using Mask = M16;
  static constexpr int W = 16;
  __m512 v;
  F16() = default;
  F16(__m512 x) : v(x) {}
  F16(float x) : v(_mm512_set1_ps(x)) {}
  static F16 load(const float* p) { return _mm512_load_ps(p); }
  static F16 loadu(const float* p) { return _mm512_loadu_ps(p); }
  static void store(float* p, F16 a) { _mm512_store_ps(p, a.v); }
  static void storeu(float* p, F16 a) { _mm512_storeu_ps(p, a.v); }
  friend F16 operator+(F16 a, F16 b) { return _mm512_add_ps(a.v, b.v); }
  friend F16 operator-(F16 a, F16 b) { return _mm512_sub_ps(a.v, b.v); }
  friend F16 operator*(F16 a, F16 b) { return _mm512_mul_ps(a.v, b.v); }
  friend F16 operator/(F16 a, F16 b) { return _mm512_div_ps(a.v, b.v); }
  friend F16 operator-(F16 a) { return _mm512_xor_ps(a.v, _mm512_set1_ps(-0.0f)); }
  friend M16 operator<(F16 a, F16 b) { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LT_OQ)}; }
  friend M16 operator<=(F16 a, F16 b) { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ)}; }
  friend M16 operator>(F16 a, F16 b) { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GT_OQ)}; }
  friend M16 operator>=(F16 a, F16 b) { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GE_OQ)}; }
  friend M16 operator!=(F16 a, F16 b) { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_NEQ_UQ)}; }
};

inline F16 vmax(F16 a, F16 b) { return _mm512_max_ps(b.v, a.v); }
inline F16 vmin(F16 a, F16 b) { return _mm512_min_ps(b.v, a.v); }
inline F16 vsqrt(F16 a) { return _mm512_sqrt_ps(a.v); }
inline F16 vabs(F16 a) { return _mm512_abs_ps(a.v); }
inline F16 select(M16 m, F16 a, F16 b) { return _mm512_mask_blend_ps(m.v, b.v, a.v); }
inline bool any(M16 m) { return m.v != 0; }
inline bool all(M16 m) { return m.v == 0xffff; }
// Bit for bit (+0 and -0 differ, a NaN equals its own bits).
inline bool sameBits(F16 a, F16 b) {
  return _mm512_cmpneq_epi32_mask(_mm512_castps_si512(a.v), _mm512_castps_si512(b.v)) == 0;
}

}  // namespace
}  // namespace blobvk::cpu::detail

#include "blobvk/cpu_simd/simd_kernel_impl.h"
#include "blobvk/cpu_simd/simd_gradient_impl.h"

namespace blobvk::cpu::detail {

void evaluateAvx512(const blobtree::Program& program, const float* x, const float* y,
                    const float* z, float* field, float* r, float* g, float* b, std::size_t n) {
  evaluateArrays<F16>(program, x, y, z, field, r, g, b, n);
}

void gradientAvx512(const blobtree::Program& program, const float* x, const float* y, const float* z,
                  float* const* outputs, bool colour, std::size_t n) {
  evaluateGradientArrays<F16>(program, x, y, z, outputs, colour, n);
}

}  // namespace blobvk::cpu::detail
