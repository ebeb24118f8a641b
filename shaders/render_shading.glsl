// Blinn-Phong with a headlight, shared by the raster fragment shader and the ray-caster so the
// two images are comparable pixel by pixel. Colours are linear in, display (gamma 2.2) out.
#ifndef BLOBVK_RENDER_SHADING_GLSL
#define BLOBVK_RENDER_SHADING_GLSL

vec3 shadeBlinnPhong(vec3 base, vec3 n, vec3 toEye, vec3 toLight) {
  if (dot(n, toEye) < 0.0) n = -n;  // two-sided: open meshes and cut surfaces stay lit
  float diffuse = max(dot(n, toLight), 0.0);
  vec3 h = normalize(toLight + toEye);
  float specular = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), 48.0) : 0.0;
  vec3 c = base * (0.18 + 0.82 * diffuse) + vec3(0.25 * specular);
  return pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2));
}

#endif
