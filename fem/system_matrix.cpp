#include "blobvk/fem/system_matrix.h"

#include "blobvk/fem/kernel_dispatch.h"
#include "blobvk/fem/node_incidence.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include <tbb/parallel_for.h>

#if BLOBVK_FEM_AVX2
#include <immintrin.h>
#endif

namespace blobvk::fem {

namespace {
constexpr std::size_t kRowGrain = 256;

template <class Body>
void forEach(std::size_t n, std::size_t grain, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
  });
}
}  // namespace

void SystemMatrix::sortedRows(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                              const std::vector<std::uint32_t>& rows, std::vector<std::uint32_t>& bound,
                              std::vector<std::uint32_t>& length, std::vector<std::uint32_t>& scratch) {
  // A row has at most 3 neighbours per incident tet: each is sorted and deduplicated in place at
  // that bound, in parallel (no per-row allocation: a vector per row cost ~35 ms at 100k tets).
  bound.assign(rows.size() + 1, 0);
  for (std::size_t k = 0; k < rows.size(); ++k) bound[k + 1] = bound[k] + 3 * incidence.count(rows[k]);
  scratch.resize(bound.back());
  length.resize(rows.size());
  forEach(rows.size(), kRowGrain, [&](std::size_t k) {
    const std::uint32_t r = rows[k];
    std::uint32_t* out = scratch.data() + bound[k];
    std::uint32_t* end = out;
    for (const std::uint32_t* q = incidence.begin(r); q != incidence.end(r); ++q)
      for (std::uint32_t v : tets[NodeIncidence::tetOf(*q)])
        if (v != r) *end++ = v;
    std::sort(out, end);
    length[k] = std::uint32_t(std::unique(out, end) - out);
  });
}

void SystemMatrix::computeSlots(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                                std::size_t node) {
  const auto first = column_.begin() + rowStart_[node], last = first + rowLength_[node];
  for (const std::uint32_t* q = incidence.begin(node); q != incidence.end(node); ++q) {
    const std::uint32_t e = NodeIncidence::tetOf(*q);
    const int a = NodeIncidence::cornerOf(*q);
    for (int b = 0; b < 4; ++b)
      tetSlots_[e][std::size_t(4 * a + b)] =
          a == b ? 0 : std::uint16_t(std::lower_bound(first, last, tets[e][std::size_t(b)]) - first);
  }
}

void SystemMatrix::moveRowToEnd(std::size_t node, std::uint32_t length) {
  rowStart_[node] = std::uint32_t(column_.size());
  rowCapacity_[node] = std::max<std::uint32_t>(4, 2 * length);
  column_.resize(column_.size() + rowCapacity_[node]);
  offDiagonal_.resize(9 * column_.size());
}

void SystemMatrix::buildPattern(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets) {
  const std::size_t n = incidence.nodeCount();
  std::vector<std::uint32_t> rows(n), bound, length, scratch;
  std::iota(rows.begin(), rows.end(), 0u);
  sortedRows(incidence, tets, rows, bound, length, scratch);
  rowStart_.resize(n);
  rowLength_ = length;
  rowCapacity_.resize(n);
  std::uint32_t total = 0;
  longestRow_ = 0;
  for (std::size_t r = 0; r < n; ++r) {
    rowStart_[r] = total;
    rowCapacity_[r] = length[r] + length[r] / 2 + 2;  // spare room for cuts
    total += rowCapacity_[r];
    longestRow_ = std::max<std::size_t>(longestRow_, length[r]);
  }
  if (longestRow_ > 0xFFFF) throw std::length_error("system matrix: a node has more than 65535 neighbours");
  column_.assign(total, 0);
  column_.reserve(total + total / 2);  // moved rows, without reallocating soon
  offDiagonal_.assign(9 * std::size_t(total), 0.0f);
  offDiagonal_.reserve(9 * column_.capacity());
  forEach(n, kRowGrain, [&](std::size_t r) { std::copy_n(scratch.data() + bound[r], length[r], column_.data() + rowStart_[r]); });
  tetSlots_.resize(tets.size());
  forEach(n, kRowGrain, [&](std::size_t r) { computeSlots(incidence, tets, r); });
  diagonal_.assign(9 * n, 0.0);
}

void SystemMatrix::updateRows(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                              const std::vector<std::uint32_t>& rows) {
  const std::size_t n = incidence.nodeCount();
  std::vector<std::uint32_t> bound, length, scratch;
  sortedRows(incidence, tets, rows, bound, length, scratch);
  rowStart_.resize(n, 0);
  rowLength_.resize(n, 0);
  rowCapacity_.resize(n, 0);
  diagonal_.resize(9 * n, 0.0);
  for (std::size_t k = 0; k < rows.size(); ++k) {  // serial: moved rows take storage in order
    const std::uint32_t r = rows[k];
    if (length[k] > rowCapacity_[r]) moveRowToEnd(r, length[k]);
    rowLength_[r] = length[k];
    longestRow_ = std::max<std::size_t>(longestRow_, length[k]);
  }
  if (longestRow_ > 0xFFFF) throw std::length_error("system matrix: a node has more than 65535 neighbours");
  forEach(rows.size(), 64, [&](std::size_t k) {
    std::copy_n(scratch.data() + bound[k], length[k], column_.data() + rowStart_[rows[k]]);
  });
  tetSlots_.resize(tets.size());
  // Each (tet, corner) belongs to one row: rows write disjoint slots.
  forEach(rows.size(), 64, [&](std::size_t k) { computeSlots(incidence, tets, rows[k]); });
}

namespace {

// The baseline product of rows [begin, end): scalar, one block row at a time.
BLOBVK_FEM_KERNEL void multiplyRowsScalar(const SystemMatrix::Rows& m, std::size_t begin, std::size_t end, const double* p,
                                          double* y) {
  for (std::size_t r = begin; r != end; ++r) {
    const double* d = m.diagonal + 9 * r;
    const double* pr = p + 3 * r;
    double y0 = d[0] * pr[0] + d[1] * pr[1] + d[2] * pr[2];
    double y1 = d[3] * pr[0] + d[4] * pr[1] + d[5] * pr[2];
    double y2 = d[6] * pr[0] + d[7] * pr[1] + d[8] * pr[2];
    const std::uint32_t first = m.start[r], last = first + m.length[r];
    for (std::uint32_t k = first; k != last; ++k) {
      const float* b = m.offDiagonal + 9 * std::size_t(k);
      const double* pc = p + 3 * std::size_t(m.column[k]);
      y0 += double(b[0]) * pc[0] + double(b[1]) * pc[1] + double(b[2]) * pc[2];
      y1 += double(b[3]) * pc[0] + double(b[4]) * pc[1] + double(b[5]) * pc[2];
      y2 += double(b[6]) * pc[0] + double(b[7]) * pc[1] + double(b[8]) * pc[2];
    }
    y[3 * r] = y0;
    y[3 * r + 1] = y1;
    y[3 * r + 2] = y2;
  }
}

#if BLOBVK_FEM_AVX2
// AVX2 + FMA: per output component a 4-lane accumulator of (row of the block) * (neighbour's
// 3 values, 4th lane 0), summed across lanes once per row: 3 fused multiply-adds per block
// instead of 9 multiplies, 9 adds and 9 conversions (the product was ~45% of a step). Masked
// loads keep every read inside its block and vector. Each row sums in its own fixed order.
__attribute__((target("arch=x86-64-v3"))) void multiplyRowsAvx2(const SystemMatrix::Rows& m, std::size_t begin,
                                                                std::size_t end, const double* p, double* y) {
  const __m256i mask3 = _mm256_setr_epi64x(-1, -1, -1, 0);
  const __m128i mask3f = _mm_setr_epi32(-1, -1, -1, 0);
  for (std::size_t r = begin; r != end; ++r) {
    const double* d = m.diagonal + 9 * r;
    const __m256d pr = _mm256_maskload_pd(p + 3 * r, mask3);
    __m256d a0 = _mm256_mul_pd(_mm256_maskload_pd(d, mask3), pr);
    __m256d a1 = _mm256_mul_pd(_mm256_maskload_pd(d + 3, mask3), pr);
    __m256d a2 = _mm256_mul_pd(_mm256_maskload_pd(d + 6, mask3), pr);
    const std::uint32_t first = m.start[r], last = first + m.length[r];
    for (std::uint32_t k = first; k != last; ++k) {
      const float* b = m.offDiagonal + 9 * std::size_t(k);
      const __m256d pc = _mm256_maskload_pd(p + 3 * std::size_t(m.column[k]), mask3);
      // Lane 3 of the first two rows reads the block's next row (finite) times pc's lane 3 (0).
      a0 = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(b)), pc, a0);
      a1 = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(b + 3)), pc, a1);
      a2 = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_maskload_ps(b + 6, mask3f)), pc, a2);
    }
    const __m256d h01 = _mm256_hadd_pd(a0, a1);  // a0_01, a1_01, a0_23, a1_23
    const __m256d h22 = _mm256_hadd_pd(a2, a2);  // a2_01, a2_01, a2_23, a2_23
    const __m256d sum = _mm256_add_pd(_mm256_permute2f128_pd(h01, h22, 0x20), _mm256_permute2f128_pd(h01, h22, 0x31));
    alignas(32) double out[4];
    _mm256_store_pd(out, sum);
    y[3 * r] = out[0];
    y[3 * r + 1] = out[1];
    y[3 * r + 2] = out[2];
  }
}

bool haveAvx2() {
  static const bool have = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return have;
}
#endif

}  // namespace

void SystemMatrix::multiplyRows(std::size_t begin, std::size_t end, const double* p, double* y) const {
  const Rows m{rowStart_.data(), rowLength_.data(), column_.data(), offDiagonal_.data(), diagonal_.data()};
#if BLOBVK_FEM_AVX2
  if (haveAvx2()) return multiplyRowsAvx2(m, begin, end, p, y);
#endif
  multiplyRowsScalar(m, begin, end, p, y);
}

void SystemMatrix::multiply(const double* p, double* y) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodeCount(), kRowGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { multiplyRows(r.begin(), r.end(), p, y); });
}

}  // namespace blobvk::fem
