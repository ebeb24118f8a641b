// Where the renderer looks from: a look-at camera (eye, target, up, vertical field of view),
// built from an orbit (azimuth, elevation, distance around a target), a scene file's camera
// section, or auto-framing of the model's bounds. Y is up. No Vulkan here.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <optional>

namespace blobvk::vk {

struct Camera {
  glm::vec3 eye{0, 0, 5}, target{0, 0, 0}, up{0, 1, 0};
  float fovYDeg = 45.0f;
  float nearPlane = 0.01f, farPlane = 100.0f;  // set by frame() from the bounds
};

// Orbit around `target`: azimuth about +Y measured from +Z towards +X, elevation above the XZ
// plane, both in degrees.
glm::vec3 orbitEye(const glm::vec3& target, float azimuthDeg, float elevationDeg, float distance);

// The distance at which a sphere of `radius` fills the smaller field of view (with 10 % margin).
float framingDistance(float radius, float fovYDeg, float aspect);

// Overrides from the command line; anything unset comes from the scene camera, then from
// auto-framing the bounds (target = centre, azimuth 30, elevation 20, distance to fit).
struct CameraRequest {
  std::optional<float> azimuthDeg, elevationDeg, distance, fovYDeg;
  std::optional<glm::vec3> eye, target;
};

// Resolves a camera for `bounds` (the Program's bounds, or the scene's grid bounds where those
// are infinite; an infinite or empty box is replaced by a unit box). Near and far planes enclose
// the bounds seen from the eye. Throws std::invalid_argument for a camera nothing can be seen
// from: a non-finite eye, target or field of view, or an eye on its target.
Camera resolveCamera(const blobtree::Aabb& bounds, const std::optional<blobtree::Camera>& scene,
                     const CameraRequest& request, float aspect);

// Same camera turned by `extraAzimuthDeg` about the vertical axis through its target.
Camera turned(const Camera& camera, float extraAzimuthDeg);

// Vulkan clip space: right-handed view, depth 0..1, Y down in the framebuffer so that row 0 of
// the image is the top of the picture.
glm::mat4 viewProjection(const Camera& camera, float aspect);

// The headlight both renderers shade with (towards the light, unit): from the eye, a little up
// and to the left, so silhouettes keep some shading.
glm::vec3 headlight(const Camera& camera);

}  // namespace blobvk::vk
