#version 450
// Sparse extraction, pass 3: the field at the R^3 points of every active brick (brick_layout.glsl),
// point (x, y, z) of the brick at grid point brick * B + (x, y, z) (points past the grid's end are
// evaluated too and never read). Invocation x is the brick-local point, y + z * (groups in y) the
// active brick. The same point formula as GridSpec::point: origin + h * (i, j, k).
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

layout(std430, set = 0, binding = 5) readonly buffer Bricks { uint bricks[]; };  // packed coordinates
layout(std430, set = 0, binding = 6) writeonly buffer Field { float field[]; };

#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  vec4 originCell;
  uint log2B;
  uint activeBricks;
  uint codeLength;
} pc;

void main() {
  uint R = (1u << pc.log2B) + 1u, P = R * R * R;
  uint l = gl_GlobalInvocationID.x;
  uint a = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (l >= P || a >= pc.activeBricks) return;
  uint z = divideSmall(l, R * R), rest = l - z * R * R;
  uint y = divideSmall(rest, R), x = rest - y * R;
  uvec3 g = (unpackBrick(bricks[a]) << pc.log2B) + uvec3(x, y, z);
  precise vec3 p = pc.originCell.xyz + pc.originCell.w * vec3(float(g.x), float(g.y), float(g.z));  // no fma
  field[a * P + l] = evaluateField(p, pc.codeLength);
}
