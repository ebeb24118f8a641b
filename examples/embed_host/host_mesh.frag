#version 450
layout(location = 0) in vec3 n;
layout(location = 0) out vec4 colour;
void main() {
  float d = abs(dot(normalize(n), normalize(vec3(0.4, 0.7, 0.6))));
  colour = vec4(vec3(0.2, 0.5, 0.9) * (0.2 + 0.8 * d), 1.0);
}
