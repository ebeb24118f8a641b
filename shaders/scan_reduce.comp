#version 450
// Reduce-then-scan, pass 1: the sum of each chunk of SCAN_CHUNK consecutive values, one invocation
// per chunk. No shared memory and no barriers: on llvmpipe (lavapipe) a workgroup barrier is a
// coroutine switch per 8-lane group, which made the shared-memory tree scan run at ~15 M values/s.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

const uint SCAN_CHUNK = 64u;  // vk::kScanChunk

layout(std430, set = 0, binding = 0) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) buffer Sums { uint sums[]; };

layout(push_constant) uniform Push {
  uint valueOffset, count, sumOffset;
} pc;

void main() {
  uint chunk = linearInvocation();
  uint base = chunk * SCAN_CHUNK;
  if (base >= pc.count) return;
  uint end = min(base + SCAN_CHUNK, pc.count);
  uint s = 0u;
  for (uint i = base; i < end; ++i) s += values[pc.valueOffset + i];
  sums[pc.sumOffset + chunk] = s;
}
