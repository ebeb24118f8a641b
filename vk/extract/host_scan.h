// The sparse extraction's exclusive scans on the host, for CPU devices (lavapipe): there the
// device's buffers are the host's memory, and a scan is a stream through it that the host runs
// at memory speed, while a compute scan pays llvmpipe's per-lane loop for every load and store
// (tower at 512 cells: 3.2 M values, about 1 ms against 35-40 ms). Same results as
// recordExclusiveScan (scan.h): sums of uint32 words modulo 2^32, whatever the order.
#pragma once

#include <cstddef>
#include <cstdint>

namespace blobvk::vk {

// Replaces values[0 .. count) by their exclusive prefix sums over the worker threads; returns the
// total.
std::uint32_t exclusiveScanInPlace(std::uint32_t* values, std::size_t count);

}  // namespace blobvk::vk
