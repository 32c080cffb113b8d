// The viewport's icons of lights (light_icons.h).
#include "light_icons.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace penumbra::editor {

LightIcon light_icon(const Light& light, const glm::mat4& world, float reach) {
  const LightFrame frame = light_frame(light, world);
  LightIcon icon;
  icon.position = frame.position;
  if (!frame.valid) return icon;
  const glm::vec3 p = frame.position, d = frame.direction;
  // Two unit vectors across the direction.
  const glm::vec3 helper = std::abs(d.y) < 0.9f ? glm::vec3(0.0f, 1.0f, 0.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
  const glm::vec3 u = glm::normalize(glm::cross(d, helper)), v = glm::cross(d, u);
  switch (light.type) {
    case Light::Type::Point: break;
    case Light::Type::Spot: {
      // The cone: a circle at `reach` along d, tan(outer) x reach wide, and four side lines.
      const float angle = std::clamp(light.outer_cone_angle, 0.0f, 1.55f);
      const float radius = reach * std::tan(angle);
      const glm::vec3 centre = p + reach * d;
      constexpr int kSegments = 16;
      for (int i = 0; i < kSegments; ++i) {
        const float a0 = 6.2831853f * float(i) / kSegments, a1 = 6.2831853f * float(i + 1) / kSegments;
        icon.lines.push_back({centre + radius * (std::cos(a0) * u + std::sin(a0) * v),
                              centre + radius * (std::cos(a1) * u + std::sin(a1) * v)});
      }
      for (const glm::vec3 side : {u, v, -u, -v}) icon.lines.push_back({p, centre + radius * side});
      break;
    }
    case Light::Type::Directional: {
      // An arrow along d with a head a fifth of its length.
      const glm::vec3 tip = p + reach * d, back = tip - 0.2f * reach * d;
      icon.lines.push_back({p, tip});
      for (const glm::vec3 side : {u, v, -u, -v}) icon.lines.push_back({tip, back + 0.1f * reach * side});
      break;
    }
    case Light::Type::Rect: {
      const glm::vec3 c[4] = {p - frame.half_x - frame.half_y, p + frame.half_x - frame.half_y,
                              p + frame.half_x + frame.half_y, p - frame.half_x + frame.half_y};
      for (int i = 0; i < 4; ++i) icon.lines.push_back({c[i], c[(i + 1) % 4]});
      icon.lines.push_back({p, p + reach * d});  // the side it lights
      break;
    }
  }
  return icon;
}

}  // namespace penumbra::editor
