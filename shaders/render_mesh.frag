#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_shading.glsl"

layout(push_constant) uniform Push {
  mat4 viewProj;
  vec4 eyeDepthBias;
  vec4 lightMode;
  vec4 lineColour;
} pc;

layout(location = 0) in vec3 worldPos;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 colour;
layout(location = 0) out vec4 outColour;

void main() {
  if (pc.lightMode.w > 0.5) {
    outColour = vec4(pc.lineColour.rgb, 1.0);
    return;
  }
  vec3 n = length(normal) > 0.0 ? normalize(normal) : vec3(0.0, 0.0, 1.0);
  vec3 toEye = normalize(pc.eyeDepthBias.xyz - worldPos);
  outColour = vec4(shadeBlinnPhong(colour, n, toEye, pc.lightMode.xyz), 1.0);
}
