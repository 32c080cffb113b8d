// What the viewport's overlays share (each module draws its own: extension.h): projection,
// bounds, colours and wireframes over ImGui's background draw list. The projection helpers are
// plain math, shared with the tests.
#pragma once

#include <optional>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "error_map.h"
#include "gizmo.h"
#include "picking.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/components.h"

struct ImDrawList;

namespace penumbra::editor {

// Display colour of an irradiance (W/m^2 per channel): exposure, then x / (1 + x) per channel.
glm::vec3 irradiance_colour(glm::vec3 e, float exposure);

// ImGui's packed colour of a linear RGB colour in [0, 1].
unsigned to_imgui(glm::vec3 c, float alpha = 1.0f);
// The 12 edges of the unit cube [0, 1]^3 through `unit_to_world`.
void draw_box(ImDrawList* draw_list, const CameraView& camera, glm::vec2 size, const glm::mat4& unit_to_world,
              unsigned colour);
// A closed polyline (the last point joins the first); segments behind the camera are skipped.
void draw_loop(ImDrawList* draw_list, const CameraView& camera, glm::vec2 size, const std::vector<glm::vec3>& loop,
               unsigned colour);

// The selection's highlight: the posed bounds of the meshes of its subtree as a white box (nothing
// for an entity without meshes, e.g. a light: its icon turns white).
void draw_selection(ImDrawList* draw_list, World& world, Entity selection, const CameraView& camera, glm::vec2 size);
// The gizmo at world point `origin` (gizmo.h): red, green and blue arrows along the columns of
// `axes` (gizmo_axes; Move: round tips, Scale: square ones) or rings about them (Rotate), the one
// being dragged (`active` axis, -1 none) brighter and thicker.
void draw_gizmo(ImDrawList* draw_list, const CameraView& camera, glm::vec3 origin, glm::vec2 size, GizmoMode mode,
                const glm::mat3& axes, int active);
// An error heat map's cells over the viewport of `size` (blue: exact, red: 50 % or more off; grey:
// within twice the cell's reference noise, where the map cannot tell).
void draw_error_map(const ErrorMap& map, glm::vec2 size, ImDrawList* draw_list);
// Every light's icon (light_icons.h) in its colour, white when selected, with a dot at its marker.
void draw_lights(ImDrawList* draw_list, World& world, Entity selection, const CameraView& camera, glm::vec2 size);

}  // namespace penumbra::editor
