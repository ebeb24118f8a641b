#version 450
// Reduce-then-scan, pass 2: exclusive scan of each block in place, plus the block's offset from
// the (already scanned) block sums. A single-block scan (the top level) writes the grand total.
// Integer sums in a fixed order: deterministic, no atomics, no inter-workgroup waiting.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) readonly buffer Sums { uint sums[]; };
layout(std430, set = 0, binding = 2) buffer Totals { uint totals[]; };

layout(push_constant) uniform Push {
  uint valueOffset, count, sumOffset;
  uint useSums;     // 0: top level (no block offsets)
  uint totalIndex;  // where the top level writes the total (~0u: nowhere)
} pc;

shared uint partial[gl_WorkGroupSize.x];

void main() {
  uint lane = gl_LocalInvocationID.x;
  uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  // Spare workgroups of a 2-D dispatch leave at once (uniformly: no barrier is split). Block 0
  // always runs so an empty scan still writes its total.
  if (block > 0u && block * gl_WorkGroupSize.x * 4u >= pc.count) return;
  uint base = block * gl_WorkGroupSize.x * 4u + lane * 4u;
  uint v[4];
  uint s = 0u;
  for (uint e = 0u; e < 4u; ++e) {
    v[e] = base + e < pc.count ? values[pc.valueOffset + base + e] : 0u;
    s += v[e];
  }
  // Inclusive Hillis-Steele scan of the per-lane sums.
  partial[lane] = s;
  barrier();
  for (uint stride = 1u; stride < gl_WorkGroupSize.x; stride <<= 1u) {
    uint add = lane >= stride ? partial[lane - stride] : 0u;
    barrier();
    partial[lane] += add;
    barrier();
  }
  uint running = partial[lane] - s;
  if (pc.useSums != 0u) running += sums[pc.sumOffset + block];
  for (uint e = 0u; e < 4u; ++e) {
    if (base + e < pc.count) values[pc.valueOffset + base + e] = running;
    running += v[e];
  }
  if (pc.useSums == 0u && pc.totalIndex != 0xffffffffu && lane == gl_WorkGroupSize.x - 1u) {
    totals[pc.totalIndex] = partial[lane];
  }
}
