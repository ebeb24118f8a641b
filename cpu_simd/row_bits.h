// Internal to the MPU polygonizer: one row of a field cache's inside/outside flags as a bit mask
// (bit i = point i of the row is inside), so crossing edges and mixed cells of a whole row come
// from a few word operations and only their set bits are visited. An MPU row has at most 65
// points (D <= 64), hence 128-bit rows.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

// The portable build targets any x86-64, whose baseline lacks POPCNT: a function that counts
// row bits in its loops is compiled twice (function multi-versioning), and the loader picks the
// POPCNT clone on every CPU that has it.
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define BLOBVK_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#endif
#endif
#ifndef BLOBVK_POPCNT_CLONES
#define BLOBVK_POPCNT_CLONES
#endif

namespace blobvk::cpu::detail {

__extension__ typedef unsigned __int128 RowBits;

inline RowBits lowBits(int n) {  // bits 0 .. n-1 set, 0 <= n <= 127
  return (RowBits(1) << n) - 1;
}

// Packs n flags (bytes that are 0 or 1). Reads up to 15 bytes past `flags + n`: the caller pads.
inline RowBits packRow(const std::uint8_t* flags, int n) {
  RowBits bits = 0;
  int i = 0;
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  for (; i < n; i += 16) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(flags + i));
    const unsigned m = unsigned(_mm_movemask_epi8(_mm_cmpgt_epi8(v, zero)));
    bits |= RowBits(m) << i;
  }
  return bits & lowBits(n);
#else
  for (; i < n; ++i) bits |= RowBits(flags[i] != 0) << i;
  return bits;
#endif
}

// Set bits of a row. __builtin_popcountll is one instruction where the function calling it is
// compiled for POPCNT (the MPU polygonizer's row passes are cloned for it, see
// kRowPassesTarget) and a libgcc call elsewhere.
inline int popCount64(std::uint64_t x) { return __builtin_popcountll(x); }
inline int popCount(RowBits bits) { return popCount64(std::uint64_t(bits)) + popCount64(std::uint64_t(bits >> 64)); }

// Bit i of a row (i < 128).
inline unsigned bitAt(RowBits bits, int i) { return unsigned(bits >> i) & 1u; }

// Calls f(i) for every set bit i, lowest first.
template <class F>
inline void forEachBit(RowBits bits, F&& f) {
  std::uint64_t word = std::uint64_t(bits);
  while (word) {
    f(std::countr_zero(word));
    word &= word - 1;
  }
  word = std::uint64_t(bits >> 64);
  while (word) {
    f(64 + std::countr_zero(word));
    word &= word - 1;
  }
}

}  // namespace blobvk::cpu::detail
