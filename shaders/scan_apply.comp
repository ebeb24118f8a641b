#version 450
// Reduce-then-scan, pass 2: exclusive scan of each chunk of SCAN_CHUNK values in place, one
// invocation per chunk, starting from the chunk's offset (its entry in the already scanned chunk
// sums). The top level (a single chunk, no sums) writes the grand total. Integer sums in a fixed
// order: deterministic, no atomics, no barriers, no inter-workgroup waiting.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

const uint SCAN_CHUNK = 64u;  // vk::kScanChunk

layout(std430, set = 0, binding = 0) buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) readonly buffer Sums { uint sums[]; };
layout(std430, set = 0, binding = 2) buffer Totals { uint totals[]; };

layout(push_constant) uniform Push {
  uint valueOffset, count, sumOffset;
  uint useSums;     // 0: top level (no chunk offsets)
  uint totalIndex;  // where the top level writes the total (~0u: nowhere)
} pc;

void main() {
  uint chunk = linearInvocation();
  uint base = chunk * SCAN_CHUNK;
  // Chunk 0 always runs so an empty scan still writes its total.
  if (chunk > 0u && base >= pc.count) return;
  uint end = min(base + SCAN_CHUNK, pc.count);
  uint running = pc.useSums != 0u ? sums[pc.sumOffset + chunk] : 0u;
  for (uint i = base; i < end; ++i) {
    uint v = values[pc.valueOffset + i];
    values[pc.valueOffset + i] = running;
    running += v;
  }
  if (pc.useSums == 0u && pc.totalIndex != 0xffffffffu && chunk == 0u) totals[pc.totalIndex] = running;
}
