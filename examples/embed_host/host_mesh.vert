#version 450
// The host's own vertex shader: positions and normals from blobvk's vertex buffers.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(push_constant) uniform Push { mat4 viewProj; } pc;
layout(location = 0) out vec3 n;
void main() {
  n = normal;
  gl_Position = pc.viewProj * vec4(position, 1.0);
}
