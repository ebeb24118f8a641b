// Stable LSD radix sort by an integer key of at most 32 bits, 11 bits per pass (2 passes for the
// keys a cut event sorts: slot and node indices below 4M). The event's sorts are a few thousand
// integers each; std::sort spent ~120 instructions per element on them, this ~15.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <utility>
#include <vector>

namespace blobvk::cutting {

// Sorts v by keyOf(element) (every key <= maxKey), keeping the input order among equal keys.
// `scratch` is a buffer reused across calls (its content is overwritten).
template <typename T, typename KeyOf>
void radixSort(std::vector<T>& v, std::vector<T>& scratch, std::uint32_t maxKey, KeyOf keyOf) {
  constexpr int kBits = 11;
  constexpr std::uint32_t kMask = (1u << kBits) - 1;
  const int passes = (std::bit_width(maxKey) + kBits - 1) / kBits;
  scratch.resize(v.size());
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = pass * kBits;
    std::array<std::uint32_t, kMask + 1> start{};
    for (const T& x : v) ++start[(keyOf(x) >> shift) & kMask];
    std::uint32_t sum = 0;
    for (std::uint32_t& s : start) sum += std::exchange(s, sum);
    for (const T& x : v) scratch[start[(keyOf(x) >> shift) & kMask]++] = x;
    v.swap(scratch);
  }
}

}  // namespace blobvk::cutting
