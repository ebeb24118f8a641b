#version 450
// Sparse extraction, pass 3: the field at the R^3 points of every active brick (brick_layout.glsl)
// and, per row of points, the inside bits (f >= iso, as in the CPU reference) packed into bit x of
// one word, which every later pass reads instead of the field (llvmpipe pays a load per lane per
// float; a row's crossing edges and cell configurations are a few bit operations on four words).
// One invocation per row of points (y + z * R): it evaluates the row's R points in a loop, so the
// row's word is built in registers instead of by a pass reading R floats back. Point (x, y, z) of
// the brick is grid point brick * B + (x, y, z) (points past the grid's end are evaluated too and
// never read). Invocation x is the row, y + z * (groups in y) the i-th brick of this dispatch,
// active brick order[orderBase + i]: the host dispatches once per field tile (vk/extract/
// brick_tiles.h), each with an evaluator pruned to its bricks. One work group spans a brick's rows
// (R^2 rounded up to a vector of 8: few idle lanes, which llvmpipe would run through the whole
// evaluator). The same point formula as GridSpec::point: origin + h * (i, j, k).
#extension GL_GOOGLE_include_directive : require
#define EVALUATOR_FIELD_ONLY  // calls evaluateField alone (eval_program.glsl)
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

layout(std430, set = 0, binding = 5) readonly buffer Bricks { uint bricks[]; };  // packed coordinates
layout(std430, set = 0, binding = 6) writeonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Masks { uint masks[]; };
layout(std430, set = 0, binding = 8) readonly buffer Order { uint order[]; };  // batch brick numbers by tile

#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  vec4 originCell;
  uint log2B;
  uint activeBricks;  // bricks of this dispatch
  uint codeLength;
  uint orderBase;     // this dispatch's first entry of `order`
} pc;

void main() {
  uint R = (1u << pc.log2B) + 1u;
  uint r = gl_GlobalInvocationID.x;
  uint i = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || i >= pc.activeBricks) return;
  uint a = order[pc.orderBase + i];
  uint z = divideSmall(r, R), y = r - z * R;
  uvec3 g = (unpackBrick(bricks[a]) << pc.log2B) + uvec3(0u, y, z);
  uint row = a * R * R + r;
  uint m = 0u;
  for (uint x = 0u; x < R; ++x) {
    precise vec3 p = pc.originCell.xyz + pc.originCell.w * vec3(float(g.x + x), float(g.y), float(g.z));  // no fma
    float f = evaluateField(p, pc.codeLength);
    field[row * R + x] = f;
    if (f >= ISO_VALUE) m |= 1u << x;
  }
  masks[row] = m;
}
