#version 450
// Direct ray-casting of the field, no mesh: one invocation per pixel marches from where its ray
// enters the Program's bounds with the safe step (iso - f) / L (L a Lipschitz bound of the
// field, vk/raycast_lipschitz.h), so it can never step across the surface; the first sample
// inside brackets the hit, which bisection refines. Shading: the gradient by central
// differences, the colour of the field's colour channel, the same Blinn-Phong as the raster.
// Output: one packed RGBA8 per pixel, row 0 at the top.
#extension GL_GOOGLE_include_directive : require
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"
#include "render_shading.glsl"

layout(std430, set = 0, binding = 5) writeonly buffer Pixels { uint pixels[]; };

layout(push_constant) uniform Push {
  vec4 eyeLipschitz;  // xyz eye, w Lipschitz bound L
  vec4 right;         // xyz camera right * tan(fovX / 2), w minimum step
  vec4 up;            // xyz camera up * tan(fovY / 2), w gradient step
  vec4 forward;       // xyz unit view direction, w bisection steps
  vec4 lo;            // xyz bounds, w max steps
  vec4 hi;            // xyz bounds
  uvec4 sizeCodeBackground;  // width, height, code length, background RGBA8
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

  float lipschitz = pc.eyeLipschitz.w, minStep = pc.right.w;
  uint maxSteps = uint(pc.lo.w);
  float t = tEnter;
  float f = evaluateField(eye + t * dir, codeLength);
  bool hit = f >= ISO_VALUE;
  float tInside = t;
  for (uint i = 0u; i < maxSteps && !hit; ++i) {
    float step = max((ISO_VALUE - f) / lipschitz, minStep);
    float tNext = t + step;
    if (tNext > tExit) break;
    float fNext = evaluateField(eye + tNext * dir, codeLength);
    if (fNext >= ISO_VALUE) {
      hit = true;
      tInside = tNext;
      break;
    }
    t = tNext;
    f = fNext;
  }
  if (!hit) return;
  // Bisection between the last outside sample t and the first inside one.
  float a = t, b = tInside;
  if (b > a) {
    uint bisections = uint(pc.forward.w);
    for (uint i = 0u; i < bisections; ++i) {
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
  // Light: the same headlight as vk::headlight (unit back, up and right vectors of the camera).
  vec3 back = -normalize(pc.forward.xyz), upDir = normalize(pc.up.xyz), rightDir = normalize(pc.right.xyz);
  vec3 toLight = normalize(back + 0.4 * upDir - 0.3 * rightDir);
  pixels[idx] = packColour(shadeBlinnPhong(colour, n, -dir, toLight));
}
