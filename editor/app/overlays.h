// Visualisations drawn over the viewport with ImGui's background draw list: probe positions
// coloured by their irradiance, invalid (filled) probes, grid bounds; the selected AO-field
// caster's bounds and field. The projection helpers are
// plain math, shared with the tests.
#pragma once

#include <optional>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/components.h"

struct ImDrawList;

namespace penumbra::editor {

// Screen position in pixels (origin top left) of world point p in a viewport of `size` pixels;
// nullopt behind the camera.
std::optional<glm::vec2> project(const CameraView& camera, glm::vec3 p, glm::vec2 size);

// World-space bounds of every mesh (empty when there is none).
Aabb world_bounds(World& world);

// Display colour of an irradiance (W/m^2 per channel): exposure, then x / (1 + x) per channel.
glm::vec3 irradiance_colour(glm::vec3 e, float exposure);

struct ProbeOverlay {
  bool probes = true;   // node positions coloured by E(+Y)
  bool invalid = true;  // nodes without an in-domain sample (filled by dilation) as red rings
  bool bounds = true;   // the grid box
  float exposure = 0.3f;  // the courtyard's nodes see 1-10 W/m^2
  int max_points = 20000;  // per grid; larger grids are subsampled by a stride
};

// Draws every IrradianceProbeGrid (bounds always; nodes once baked). Returns the nodes drawn.
int draw_probe_overlay(World& world, const CameraView& camera, glm::vec2 size, const ProbeOverlay& options,
                       ImDrawList* draw_list);

// The selected AO-field caster's field (lighting_views.h): its bounds as wireframes and a floor
// slice of receivers coloured by its occlusion, recomputed every frame so it follows a dragged caster.
struct AOFieldOverlay {
  bool bounds = true;   // the hull (radial fit) or grid cube, and the falloff sphere
  bool slice = true;    // once baked
  int resolution = 32;  // slice points per side (~0.1 ms at 32)
  float height = 0.0f;  // of the slice above the caster's lowest point, metres
};

// Draws the overlay for `caster` (nothing when it is not an AO-field caster). Returns the slice
// points drawn.
int draw_ao_field_overlay(World& world, Entity caster, const CameraView& camera, glm::vec2 size,
                          const AOFieldOverlay& options, ImDrawList* draw_list);

}  // namespace penumbra::editor
