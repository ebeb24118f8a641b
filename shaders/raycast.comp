#version 450
// Direct ray-casting of the field, no mesh: one invocation per pixel marches from where its ray
// enters the Program's bounds. The bounds are split into cells, each with its own Lipschitz
// bound L of the field (vk/render/raycast_lipschitz.h: a far, steep component only slows the rays that
// pass near it). The ray walks the cells in order (a 3-D DDA) and, inside a cell, steps
// (iso - f) / L, never past the cell's exit face: it can never step across the surface (down to
// the step floor: a crossing where the field rises less than minRise above iso may be missed). The first sample inside
// brackets the hit, which bisection refines. A ray that runs out of its step budget before
// leaving the bounds is counted (binding 7) and its pixel set to the budget marker colour, so a
// surface is never dropped silently. Shading: the gradient by central differences, the colour
// of the field's colour channel, the same Blinn-Phong as the raster.
// Output: one packed RGBA8 per pixel, row 0 at the top.
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
// llvmpipe ends an invocation's loops after 65,535 iterations in all: the march counts them
// (eval_loop_count.glsl) and stops short, counted and marked like a ray out of steps.
#define EVAL_COUNT_LOOPS
#include "eval_program.glsl"
#include "common.glsl"
#include "render_shading.glsl"

layout(std430, set = 0, binding = 5) writeonly buffer Pixels { uint pixels[]; };
layout(std430, set = 0, binding = 6) readonly buffer CellBounds { float cellLipschitz[]; };
layout(std430, set = 0, binding = 7) buffer Exhausted { uint exhaustedRays; };

const uint BUDGET_MARKER = 0xffff00ffu;  // opaque magenta (RGBA8): vk::kRaycastBudgetMarker

layout(push_constant) uniform Push {
  vec4 eyeLipschitz;  // xyz eye, w unused (the bounds are per cell)
  vec4 right;         // xyz camera right * tan(fovX / 2), w minimum step
  vec4 up;            // xyz camera up * tan(fovY / 2), w gradient step
  vec4 forward;       // xyz unit view direction, w bisection steps
  vec4 lo;            // xyz bounds, w max steps
  vec4 hi;            // xyz bounds, w loop iterations a pixel may run (the driver's limit less a margin)
  uvec4 sizeCodeBackground;  // width, height, code length, background RGBA8
  uvec4 cells;               // xyz cells of the bounds (x fastest in cellLipschitz), w min rise (float bits)
} pc;

uint packColour(vec3 c) {
  uvec3 v = uvec3(clamp(c, 0.0, 1.0) * 255.0 + 0.5);
  return v.r | (v.g << 8) | (v.b << 16) | (255u << 24);
}

void main() {
  uint idx = linearInvocation();
  uint width = pc.sizeCodeBackground.x, height = pc.sizeCodeBackground.y;
  if (idx >= width * height) return;
  uint codeLength = pc.sizeCodeBackground.z;
  float px = float(idx % width) + 0.5, py = float(idx / width) + 0.5;
  vec2 ndc = vec2(2.0 * px / float(width) - 1.0, 1.0 - 2.0 * py / float(height));
  vec3 eye = pc.eyeLipschitz.xyz;
  vec3 dir = normalize(pc.forward.xyz + ndc.x * pc.right.xyz + ndc.y * pc.up.xyz);

  // Slab test against the bounds.
  vec3 inv = 1.0 / dir;
  vec3 t0 = (pc.lo.xyz - eye) * inv, t1 = (pc.hi.xyz - eye) * inv;
  vec3 tmin = min(t0, t1), tmax = max(t0, t1);
  float tEnter = max(max(max(tmin.x, tmin.y), tmin.z), 0.0);
  float tExit = min(min(tmax.x, tmax.y), tmax.z);
  pixels[idx] = pc.sizeCodeBackground.w;
  if (tEnter >= tExit) return;

  float minStep = pc.right.w, minRise = uintBitsToFloat(pc.cells.w);
  uint maxSteps = uint(pc.lo.w);
  ivec3 dims = ivec3(pc.cells.xyz);
  vec3 cellSize = (pc.hi.xyz - pc.lo.xyz) / vec3(dims);
  float t = tEnter;
  // The cell holding the entry point, then the ray parameter of each axis's next cell face.
  ivec3 cell = clamp(ivec3(floor((eye + t * dir - pc.lo.xyz) / cellSize)), ivec3(0), dims - 1);
  ivec3 cellStep = ivec3(dir.x > 0.0 ? 1 : -1, dir.y > 0.0 ? 1 : -1, dir.z > 0.0 ? 1 : -1);
  vec3 tFace = (pc.lo.xyz + (vec3(cell) + vec3(greaterThan(dir, vec3(0.0)))) * cellSize - eye) * inv;
  vec3 tDelta = abs(cellSize * inv);
  // A ray parallel to an axis never crosses that axis's faces.
  bvec3 parallel = equal(dir, vec3(0.0));
  tFace = mix(tFace, vec3(3.0e38), parallel);
  tDelta = mix(tDelta, vec3(3.0e38), parallel);
  // Loop iterations: a sample's (the most any took so far), and what the shading after a hit
  // takes (the bisection, six gradient samples and the colour); a step is not taken unless both
  // fit in what is left of the driver's limit.
  float loopBudget = pc.hi.w;
  uint shadingSamples = uint(pc.forward.w) + 8u;
  uint ticks = evalLoopIterations;
  float f = evaluateField(eye + t * dir, codeLength);
  uint perSample = evalLoopIterations - ticks + 1u;
  bool hit = f >= ISO_VALUE, left = false, outOfLoops = false;
  float tInside = t;
  uint i = 0u;
  for (; i < maxSteps && !hit; ++i) {
    EVAL_LOOP_TICK();
    if (float(evalLoopIterations) + float((shadingSamples + 1u) * perSample) + 64.0 > loopBudget) {
      outOfLoops = true;
      break;
    }
    float tCellExit = min(min(tFace.x, tFace.y), tFace.z);
    float lipschitz = cellLipschitz[(cell.z * dims.y + cell.y) * dims.x + cell.x];
    // L = 0: the field is 0 throughout the cell, nothing to find before its exit. The floor on
    // the step (progress near the surface) shrinks with 1 / L, so that in a steep cell it cannot
    // jump over a feature rising more than minRise above the iso value: such a crossing is at
    // least 2 minRise / L long.
    float safe = lipschitz > 0.0 ? max((ISO_VALUE - f) / lipschitz, min(minStep, minRise / lipschitz)) : 3.0e38;
    float tNext = t + safe;
    if (tNext >= tCellExit) {
      // Into the next cell along the axis whose face comes first.
      tNext = max(tCellExit, t);
      int axis = tFace.x <= tFace.y && tFace.x <= tFace.z ? 0 : (tFace.y <= tFace.z ? 1 : 2);
      cell[axis] += cellStep[axis];
      tFace[axis] += tDelta[axis];
      if (cell[axis] < 0 || cell[axis] >= dims[axis]) tNext = max(tNext, tExit);
    }
    if (tNext >= tExit) {
      // The last stretch to the exit: sampled there too, a surface touching the bounds' face.
      left = true;
      tNext = tExit;
    }
    ticks = evalLoopIterations;
    float fNext = evaluateField(eye + tNext * dir, codeLength);
    perSample = max(perSample, evalLoopIterations - ticks + 1u);
    if (fNext >= ISO_VALUE) {
      hit = true;
      tInside = tNext;
      break;
    }
    t = tNext;
    f = fNext;
    if (left) break;
  }
  if (!hit && !left && (i >= maxSteps || outOfLoops)) {
    // Out of budget inside the bounds: a surface may lie further on. Count and mark it.
    atomicAdd(exhaustedRays, 1u);
    pixels[idx] = BUDGET_MARKER;
    return;
  }
  if (!hit) return;
  // Bisection between the last outside sample t and the first inside one.
  float a = t, b = tInside;
  if (b > a) {
    uint bisections = uint(pc.forward.w);
    for (uint i = 0u; i < bisections; ++i) {
      EVAL_LOOP_TICK();
      float m = 0.5 * (a + b);
      if (evaluateField(eye + m * dir, codeLength) >= ISO_VALUE) b = m; else a = m;
    }
  }
  vec3 p = eye + 0.5 * (a + b) * dir;
  float h = pc.up.w;
  vec3 grad = vec3(evaluateField(p + vec3(h, 0, 0), codeLength) - evaluateField(p - vec3(h, 0, 0), codeLength),
                   evaluateField(p + vec3(0, h, 0), codeLength) - evaluateField(p - vec3(0, h, 0), codeLength),
                   evaluateField(p + vec3(0, 0, h), codeLength) - evaluateField(p - vec3(0, 0, h), codeLength));
  vec3 n = length(grad) > 0.0 ? -normalize(grad) : -dir;
  vec3 colour;
  evaluateFieldColour(p, codeLength, colour);
  if (float(evalLoopIterations) >= loopBudget) {
    // The shading took more than its share and the driver may have cut it short: say so.
    atomicAdd(exhaustedRays, 1u);
    pixels[idx] = BUDGET_MARKER;
    return;
  }
  // Light: the same headlight as vk::headlight (unit back, up and right vectors of the camera).
  vec3 back = -normalize(pc.forward.xyz), upDir = normalize(pc.up.xyz), rightDir = normalize(pc.right.xyz);
  vec3 toLight = normalize(back + 0.4 * upDir - 0.3 * rightDir);
  pixels[idx] = packColour(shadeBlinnPhong(colour, n, -dir, toLight));
}
