// Exclusive prefix sum of uint32 values on the GPU: reduce-then-scan, recursive over chunk sums.
// Deterministic (fixed summation order), no atomics, no inter-workgroup waiting (lavapipe gives
// no forward-progress guarantee), no shared memory or barriers: each invocation sums, then scans,
// kScanChunk consecutive values serially (shaders/scan_*.comp).
#pragma once

#include "blobvk/vk/device/context.h"

#include <cstdint>

namespace blobvk::vk {

inline constexpr std::uint32_t kScanWorkgroup = 64;  // invocations per workgroup
inline constexpr std::uint32_t kScanChunk = 64;      // values per invocation (SCAN_CHUNK)

// uint32 words of scratch a scan of `count` values needs (0 for a single chunk).
std::uint64_t scanScratchWords(std::uint64_t count);

// Records an in-place exclusive scan of values[valueOffset .. +count) (offsets in uint32
// elements) and writes the total to totals[totalIndex]. Leaves the results behind a
// computeBarrier-compatible state: the caller adds a barrier before reading them.
void recordExclusiveScan(Recorder& rec, VkBuffer values, std::uint32_t valueOffset,
                         std::uint32_t count, VkBuffer scratch, std::uint32_t scratchOffset,
                         VkBuffer totals, std::uint32_t totalIndex);

}  // namespace blobvk::vk
