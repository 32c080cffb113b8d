// The transform gizmo's math at the selection's position, which the pointer grabs and drags (the
// app draws it and feeds the pointer; tests call these): in Move mode three arrows along the world
// axes, in Rotate mode three rings about them, in Scale mode three arrows along the entity's own
// axes (gizmo_axes), each of which stretches the entity's scale of that axis.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"

namespace penumbra::editor {

enum class GizmoMode : std::uint8_t { Move, Rotate, Scale };
// "move", "rotate", "scale".
const char* to_string(GizmoMode mode);

struct GizmoHandles {
  GizmoMode mode = GizmoMode::Move;
  glm::vec2 origin{0.0f};                        // the selection's position on screen, pixels
  std::array<std::optional<glm::vec2>, 3> tips;  // each arrow's tip (+X, +Y, +Z); none behind the camera
  // Rotate: each ring about +X, +Y, +Z (radius `length`) on screen, the points in front of the
  // camera in order (a closed loop when all are).
  std::array<std::vector<glm::vec2>, 3> rings;
  float length = 0.0f;  // the arrows' length and the rings' radius in metres
};

// The handles at world point `origin` in a viewport of `size` pixels: arrows (rings) a fifth of
// the distance to the camera long (wide), so they keep their size on screen, along (about) the unit
// columns of `axes`. Nullopt when `origin` is behind the camera. O(1) (48 points a ring).
std::optional<GizmoHandles> gizmo_handles(const CameraView& camera, glm::vec3 origin, glm::vec2 size,
                                          GizmoMode mode = GizmoMode::Move, const glm::mat3& axes = glm::mat3(1.0f));

// The directions of `mode`'s handles for entity `e`, as unit columns: the world axes to move and
// rotate along and about, the entity's own axes in the world (its WorldTransform's columns,
// normalised) to scale along; the world axes when it has no WorldTransform or a degenerate one. O(1).
glm::mat3 gizmo_axes(const World& world, Entity e, GizmoMode mode);

// The axis (0 x, 1 y, 2 z) whose arrow (ring) passes within `reach` pixels of `pointer`, the
// nearest; -1 for none. O(1).
int pick_gizmo_axis(const GizmoHandles& handles, glm::vec2 pointer, float reach = 6.0f);

// Rotate mode: the angle in radians about unit `axis` through `origin` by which the pointer turned
// from pixel `from` to `to` around the origin's pixel, right-handed about the axis (a
// counter-clockwise turn on screen is positive when the axis points at the camera). O(1).
float rotate_about_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, glm::vec2 from, glm::vec2 to,
                        glm::vec2 size);
// Scale mode: the factor along an axis for a drag from `from` to `to` with arrows `length` long:
// 1 plus the drag's offset along the axis (drag_along_axis) over the length, at least 0.01. O(1).
float scale_along_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, float length, glm::vec2 from,
                       glm::vec2 to, glm::vec2 size);

// Dragging along an axis: the world offset along unit `axis` through `origin` that moves the point
// of the axis line under the pointer at pixel `from` to the one under `to` (each the axis point
// nearest the pointer's ray). An axis pointing at the camera projects to a point, so a drag barely
// moves along it; zero when a ray is parallel to the axis or not finite. O(1).
glm::vec3 drag_along_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, glm::vec2 from, glm::vec2 to,
                          glm::vec2 size);

// The world matrix that entity `e`'s Transform is relative to: its live parent's WorldTransform,
// the identity for a root. What turns a move or turn in world space into the local Transform a
// drag edits. O(1).
glm::mat4 parent_world_matrix(const World& world, Entity e);

}  // namespace penumbra::editor
