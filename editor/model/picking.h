// Click-to-select in the viewport: what is under a pixel. Kept out of the app so that tests check
// it. Main thread (reads the World).
#pragma once

#include <optional>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/scene/camera.h"

namespace penumbra::editor {

// Screen position in pixels (origin top left) of world point p in a viewport of `size` pixels;
// nullopt behind the camera. What the overlays, the gizmo and picking project with. O(1).
std::optional<glm::vec2> project(const CameraView& camera, glm::vec3 p, glm::vec2 size);

// Pixels around a light's position within which a click picks the light (lights have no geometry).
inline constexpr float kLightPickRadius = 12.0f;

// The entity a click at `pixel` of a viewport of `size` pixels (origin top left) picks: a light
// whose position projects within kLightPickRadius of it (the nearest), else the mesh the camera
// ray hits first (static, movable and skinned meshes as posed now, traced with Embree), else null.
// Errors: the ray scene's (a World whose geometry Embree refuses). Cost: one BVH build over the
// World's triangles (milliseconds for the built-in scenes), then one ray.
Result<Entity> pick(World& world, const CameraView& camera, glm::vec2 pixel, glm::vec2 size);

}  // namespace penumbra::editor
