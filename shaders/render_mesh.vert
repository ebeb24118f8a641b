#version 450
// Mesh vertices for the offscreen renderer: float3 positions, normals and colours in three
// tightly packed vertex buffers (the layout both polygonizers produce).
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec3 inColour;

layout(push_constant) uniform Push {
  mat4 viewProj;
  vec4 eyeDepthBias;   // xyz eye, w depth pulled towards the camera (wireframe lines)
  vec4 lightMode;      // xyz unit direction towards the light, w: 0 shaded, 1 flat line colour
  vec4 lineColour;
} pc;

layout(location = 0) out vec3 worldPos;
layout(location = 1) out vec3 normal;
layout(location = 2) out vec3 colour;

void main() {
  worldPos = inPosition;
  normal = inNormal;
  colour = inColour;
  gl_Position = pc.viewProj * vec4(inPosition, 1.0);
  gl_Position.z -= pc.eyeDepthBias.w * gl_Position.w;
}
