#include "blobvk/vk/render/render_camera.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace blobvk::vk {
namespace {

blobtree::Aabb usableBounds(const blobtree::Aabb& b) {
  if (b.finite()) return b;
  blobtree::Aabb unit;
  unit.lo = glm::vec3(-1.0f);
  unit.hi = glm::vec3(1.0f);
  return unit;
}

glm::vec3 toVec3(const blobtree::Vec3& v) { return glm::vec3(float(v.x), float(v.y), float(v.z)); }

}  // namespace

glm::vec3 orbitEye(const glm::vec3& target, float azimuthDeg, float elevationDeg, float distance) {
  const float az = glm::radians(azimuthDeg), el = glm::radians(elevationDeg);
  return target + distance * glm::vec3(std::cos(el) * std::sin(az), std::sin(el),
                                       std::cos(el) * std::cos(az));
}

float framingDistance(float radius, float fovYDeg, float aspect) {
  const float halfY = glm::radians(fovYDeg) * 0.5f;
  const float halfX = std::atan(std::tan(halfY) * aspect);
  return 1.1f * radius / std::sin(std::min(halfX, halfY));
}

Camera resolveCamera(const blobtree::Aabb& rawBounds, const std::optional<blobtree::Camera>& scene,
                     const CameraRequest& request, float aspect) {
  const blobtree::Aabb bounds = usableBounds(rawBounds);
  const glm::vec3 centre = 0.5f * (bounds.lo + bounds.hi);
  const float radius = std::max(0.5f * glm::length(bounds.hi - bounds.lo), 1e-3f);
  Camera cam;
  cam.fovYDeg = request.fovYDeg.value_or(scene ? float(scene->fovYDeg) : 45.0f);
  if (scene && scene->up) cam.up = glm::normalize(toVec3(*scene->up));
  cam.target = request.target.value_or(scene && scene->target ? toVec3(*scene->target) : centre);

  const bool orbitRequested = request.azimuthDeg || request.elevationDeg || request.distance;
  if (request.eye) {
    cam.eye = *request.eye;
  } else if (!orbitRequested && scene && scene->eye) {
    cam.eye = toVec3(*scene->eye);
  } else {
    const float az = request.azimuthDeg.value_or(
        scene && scene->azimuthDeg ? float(*scene->azimuthDeg) : 30.0f);
    const float el = request.elevationDeg.value_or(
        scene && scene->elevationDeg ? float(*scene->elevationDeg) : 20.0f);
    const float fit = framingDistance(radius + glm::length(cam.target - centre), cam.fovYDeg, aspect);
    const float dist = request.distance.value_or(
        scene && scene->distance ? float(*scene->distance) : fit);
    cam.eye = orbitEye(cam.target, az, el, dist);
  }
  // A camera nothing can be seen from: refused, not rendered as a blank image.
  const auto finite3 = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!finite3(cam.eye) || !finite3(cam.target) || !(cam.fovYDeg > 0.0f && cam.fovYDeg < 180.0f))
    throw std::invalid_argument("the camera is not finite (eye, target or field of view)");
  if (!(glm::length(cam.target - cam.eye) > 0.0f)) throw std::invalid_argument("the camera's eye and target coincide");
  if (glm::length(glm::cross(cam.target - cam.eye, cam.up)) < 1e-6f * glm::length(cam.target - cam.eye)) {
    cam.up = glm::vec3(0, 0, -1);  // looking straight down or up: pick another up
  }
  const float toCentre = glm::length(centre - cam.eye);
  cam.farPlane = toCentre + 2.0f * radius;
  cam.nearPlane = std::max(toCentre - 2.0f * radius, cam.farPlane * 1e-4f);
  return cam;
}

Camera turned(const Camera& camera, float extraAzimuthDeg) {
  Camera c = camera;
  const float a = glm::radians(extraAzimuthDeg);
  const glm::vec3 d = camera.eye - camera.target;
  c.eye = camera.target + glm::vec3(d.x * std::cos(a) + d.z * std::sin(a), d.y,
                                    -d.x * std::sin(a) + d.z * std::cos(a));
  return c;
}

glm::mat4 viewProjection(const Camera& camera, float aspect) {
  glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(camera.fovYDeg), aspect, camera.nearPlane,
                                         camera.farPlane);
  proj[1][1] *= -1.0f;  // Vulkan's framebuffer Y points down
  return proj * glm::lookAtRH(camera.eye, camera.target, camera.up);
}

glm::vec3 headlight(const Camera& camera) {
  const glm::vec3 back = glm::normalize(camera.eye - camera.target);
  const glm::vec3 right = glm::normalize(glm::cross(-back, camera.up));
  const glm::vec3 up = glm::cross(right, -back);
  return glm::normalize(back + 0.4f * up - 0.3f * right);
}

}  // namespace blobvk::vk
