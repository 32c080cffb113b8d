// The viewport's icons of lights, as world-space line segments that the app projects and draws
// around a screen-space marker at each light's position, so that every light can be found and
// picked (picking.h takes a light within 12 px of its marker).
#pragma once

#include <array>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "penumbra/scene/components.h"

namespace penumbra::editor {

struct LightIcon {
  glm::vec3 position{0.0f};  // where the marker goes: the light's origin (a rect's centre)
  std::vector<std::array<glm::vec3, 2>> lines;
};

// The icon of `light` with world matrix `world` (light_frame): a spot light's cone, from its apex
// to a circle `reach` metres along its direction as wide as the outer cone angle (16 segments and
// 4 side lines); a directional light's arrow, `reach` metres along its direction with a head; a rect
// light's outline at its true size and its normal, `reach` long; a point light none (the marker
// alone). `reach` > 0: the icon's size in metres (the app passes a fraction of the distance to the
// camera, so icons keep their size on screen). No lines for a matrix light_frame rejects. O(1).
LightIcon light_icon(const Light& light, const glm::mat4& world, float reach);

}  // namespace penumbra::editor
