#version 450
// Field at the points of a z-slab of the grid: point (i, j, k0 + l) for l < layers, written
// slab-linearly (i fastest). The same point formula as GridSpec::point: origin + h * (i, j, k).
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

layout(std430, set = 0, binding = 5) writeonly buffer Field { float field[]; };

layout(push_constant) uniform Push {
  vec4 originCell;  // xyz origin, w cell size
  uint nx, ny;      // points per axis
  uint count;       // points in the slab (nx * ny * layers)
  uint k0;          // first z layer
  uint codeLength;
} pc;

void main() {
  uint idx = linearInvocation();
  if (idx >= pc.count) return;
  uint i = idx % pc.nx, j = (idx / pc.nx) % pc.ny, k = pc.k0 + idx / (pc.nx * pc.ny);
  vec3 p = pc.originCell.xyz + pc.originCell.w * vec3(float(i), float(j), float(k));
  field[idx] = evaluateField(p, pc.codeLength);
}
