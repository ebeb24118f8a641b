#version 450
// Reduce-then-scan, pass 1: the sum of each block of BLOCK = 4 * workgroup size values.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) buffer Sums { uint sums[]; };

layout(push_constant) uniform Push {
  uint valueOffset, count, sumOffset;
} pc;

shared uint partial[gl_WorkGroupSize.x];

void main() {
  uint lane = gl_LocalInvocationID.x;
  uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  // Spare workgroups of a 2-D dispatch leave at once (uniformly: no barrier is split). Block 0
  // always runs so an empty scan still writes its total.
  if (block > 0u && block * gl_WorkGroupSize.x * 4u >= pc.count) return;
  uint base = block * gl_WorkGroupSize.x * 4u + lane * 4u;
  uint s = 0u;
  for (uint e = 0u; e < 4u; ++e) {
    if (base + e < pc.count) s += values[pc.valueOffset + base + e];
  }
  partial[lane] = s;
  barrier();
  for (uint stride = gl_WorkGroupSize.x / 2u; stride > 0u; stride >>= 1u) {
    if (lane < stride) partial[lane] += partial[lane + stride];
    barrier();
  }
  if (lane == 0u) sums[pc.sumOffset + block] = partial[0];
}
