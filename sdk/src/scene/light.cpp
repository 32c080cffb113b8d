// Lights in world space (see components.h).
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "penumbra/scene/components.h"

namespace penumbra {

LightFrame light_frame(const Light& light, const glm::mat4& world) {
  const glm::mat3 basis(world);
  LightFrame f;
  f.position = glm::vec3(world[3]);
  const glm::vec3 forward = basis * glm::vec3(0.0f, 0.0f, -1.0f);
  f.half_x = basis * glm::vec3(0.5f * light.size.x, 0.0f, 0.0f);
  f.half_y = basis * glm::vec3(0.0f, 0.5f * light.size.y, 0.0f);
  const float len = glm::length(forward);
  const auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  f.valid = std::isfinite(len) && len > 0.0f && finite(f.position) && finite(f.half_x) && finite(f.half_y);
  f.zero_rect = light.type == Light::Type::Rect && !(glm::length(glm::cross(f.half_x, f.half_y)) > 0.0f);
  if (f.valid) f.direction = forward / len;
  return f;
}

}  // namespace penumbra
