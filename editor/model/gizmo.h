// The translate gizmo's math: three arrows along the world axes at the selection's position, which
// the pointer grabs and drags (the app draws them and feeds the pointer; tests call these).
#pragma once

#include <array>
#include <optional>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/render/renderer.h"

namespace penumbra::editor {

struct GizmoHandles {
  glm::vec2 origin{0.0f};                        // the selection's position on screen, pixels
  std::array<std::optional<glm::vec2>, 3> tips;  // each arrow's tip (+X, +Y, +Z); none behind the camera
  float length = 0.0f;                           // the arrows' length in metres
};

// The handles at world point `origin` in a viewport of `size` pixels: arrows a fifth of the
// distance to the camera long, so they keep their size on screen. Nullopt when `origin` is behind
// the camera. O(1).
std::optional<GizmoHandles> gizmo_handles(const CameraView& camera, glm::vec3 origin, glm::vec2 size);

// The axis (0 x, 1 y, 2 z) whose arrow passes within `reach` pixels of `pointer`, the nearest;
// -1 for none. O(1).
int pick_gizmo_axis(const GizmoHandles& handles, glm::vec2 pointer, float reach = 6.0f);

// Dragging along an axis: the world offset along unit `axis` through `origin` that moves the point
// of the axis line under the pointer at pixel `from` to the one under `to` (each the axis point
// nearest the pointer's ray). An axis pointing at the camera projects to a point, so a drag barely
// moves along it; zero when a ray is parallel to the axis or not finite. O(1).
glm::vec3 drag_along_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, glm::vec2 from, glm::vec2 to,
                          glm::vec2 size);

}  // namespace penumbra::editor
