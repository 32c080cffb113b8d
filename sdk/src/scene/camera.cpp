// Camera views and primary rays (Vulkan clip conventions: y down, depth 0..1).
#include "penumbra/scene/camera.h"

#include <cmath>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/components.h"

namespace penumbra {
namespace {

// Right-handed perspective to Vulkan clip space (depth 0..1, y pointing down the image).
glm::mat4 vulkan_perspective(float yfov, float aspect, float znear, float zfar) {
  glm::mat4 p = glm::perspectiveRH_ZO(yfov, aspect, znear, zfar);
  p[1][1] = -p[1][1];
  return p;
}

}  // namespace

CameraView camera_view(const World& world, Entity camera, float aspect) {
  CameraView v;
  const auto* cam = world.try_get<Camera>(camera);
  const auto* wt = world.try_get<WorldTransform>(camera);
  const Camera c = cam ? *cam : Camera{};
  const glm::mat4 camera_to_world = wt ? wt->matrix : glm::mat4(1.0f);
  v.position = glm::vec3(camera_to_world[3]);
  v.view = glm::affineInverse(camera_to_world);
  v.projection = vulkan_perspective(c.yfov, aspect, c.znear, c.zfar);  // the target's aspect wins over the stored one
  return v;
}

CameraView framing_camera_view(World& world, float aspect) {
  Aabb bounds = posed_bounds(world);
  if (bounds.empty()) bounds.extend(glm::vec3(0.0f));
  const glm::vec3 centre = bounds.center();
  const float radius = std::max(0.5f * glm::length(bounds.extent()), 0.01f);
  const float yfov = 0.8f;
  // From the front (+Z) and above, far enough that the bounding sphere fits the vertical field.
  const float distance = radius / std::sin(0.5f * yfov);
  const glm::vec3 eye = centre + distance * glm::normalize(glm::vec3(0.0f, 0.45f, 1.0f));
  return look_at_view(eye, centre, yfov, aspect, distance * 0.01f, distance + 2.0f * radius);
}

CameraView look_at_view(glm::vec3 eye, glm::vec3 target, float yfov, float aspect, float znear, float zfar) {
  CameraView v;
  v.position = eye;
  v.view = glm::lookAtRH(eye, target, glm::vec3(0.0f, 1.0f, 0.0f));
  v.projection = vulkan_perspective(yfov, aspect, znear, zfar);
  return v;
}

CameraRay camera_ray(const glm::mat4& clip_to_world, glm::vec2 pixel, std::uint32_t width, std::uint32_t height) {
  const glm::vec2 ndc(2.0f * pixel.x / float(width) - 1.0f, 2.0f * pixel.y / float(height) - 1.0f);
  const glm::vec4 near = clip_to_world * glm::vec4(ndc, 0.0f, 1.0f);
  const glm::vec4 far = clip_to_world * glm::vec4(ndc, 1.0f, 1.0f);
  CameraRay r;
  r.origin = glm::vec3(near) / near.w;
  r.direction = glm::normalize(glm::vec3(far) / far.w - r.origin);
  return r;
}

}  // namespace penumbra
