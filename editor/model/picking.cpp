// Click-to-select (picking.h).
#include "picking.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

std::optional<glm::vec2> project(const CameraView& camera, glm::vec3 p, glm::vec2 size) {
  const glm::vec4 clip = camera.projection * camera.view * glm::vec4(p, 1.0f);
  if (clip.w <= 1e-6f) return std::nullopt;
  const glm::vec2 ndc(clip.x / clip.w, clip.y / clip.w);  // Vulkan: y already points down
  return glm::vec2((ndc.x * 0.5f + 0.5f) * size.x, (ndc.y * 0.5f + 0.5f) * size.y);
}

Result<Entity> pick(World& world, const CameraView& camera, glm::vec2 pixel, glm::vec2 size) {
  // Lights first: a marker under the pointer wins over the surface behind it.
  Entity light;
  float nearest = kLightPickRadius;
  const glm::mat4 world_to_clip = camera.projection * camera.view;
  world.view<const Light, const WorldTransform>().each([&](Entity e, const Light&, const WorldTransform& wt) {
    const auto p = project(camera, glm::vec3(wt.matrix[3]), size);
    if (!p) return;
    if (const float d = glm::distance(*p, pixel); d < nearest) {
      nearest = d;
      light = e;
    }
  });
  if (light) return light;
  RaySceneOptions options;
  options.include_dynamic = true;
  options.quality = RaySceneOptions::Quality::Low;
  auto rays = RayScene::build(world, options);
  if (!rays) return rays.error();
  const CameraRay through = camera_ray(glm::inverse(world_to_clip), pixel, static_cast<std::uint32_t>(size.x),
                                       static_cast<std::uint32_t>(size.y));
  Ray ray;
  ray.origin = through.origin;
  ray.direction = through.direction;
  Hit hit;
  if (!rays->intersect(ray, hit)) return Entity::null();
  return hit.entity;
}

}  // namespace penumbra::editor
