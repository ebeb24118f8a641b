#version 450
// Field at the points of one tile of a z-slab: invocation (a, b, c) evaluates grid point
// (i0 + a, j0 + b, k0 + c) for a < tileNx, b < tileNy, and writes it into the slab buffer at the
// grid-layout index of (i, j, k - outK0) (i fastest), so the tiles of a slab fill it like one
// dispatch would. The same point formula as GridSpec::point: origin + h * (i, j, k). With the
// specialised evaluator each tile has its own pipeline, pruned to the tile (vk/eval/field_tiles.h).
// Work groups: shaders/grid_dispatch.glsl.
#extension GL_GOOGLE_include_directive : require
#define EVALUATOR_FIELD_ONLY  // calls evaluateField alone (eval_program.glsl)
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "grid_dispatch.glsl"

layout(std430, set = 0, binding = 5) writeonly buffer Field { float field[]; };

layout(push_constant) uniform Push {
  vec4 originCell;    // xyz origin, w cell size
  uint nx, ny;        // grid points per axis (the slab buffer's layout)
  uint tileNx, tileNy;
  uint i0, j0, k0;    // first point of the dispatch
  uint outK0;         // the slab buffer's first z layer
  uint codeLength;
} pc;

void main() {
  uvec3 t = gl_GlobalInvocationID;
  if (t.x >= pc.tileNx || t.y >= pc.tileNy) return;
  uint i = pc.i0 + t.x, j = pc.j0 + t.y, k = pc.k0 + t.z;
  precise vec3 p = pc.originCell.xyz + pc.originCell.w * vec3(float(i), float(j), float(k));  // no fma
  field[((k - pc.outK0) * pc.ny + j) * pc.nx + i] = evaluateField(p, pc.codeLength);
}
