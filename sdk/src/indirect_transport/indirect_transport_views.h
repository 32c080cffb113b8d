// What the editor's inspector shows about the indirect transport, kept out of the app so that
// tests check it: the baked operator's figures and this frame's lightmap, per transport entity and
// per receiving mesh. Plain functions over a World; main thread (they read components). Part of
// the editor (indirect_transport_editor.cpp draws them).
#pragma once

#include <cstddef>
#include <cstdint>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/scene/camera.h"

namespace penumbra::editor {

// Irradiance statistics of lightmap leaves (W/m^2, the mean of R, G and B per leaf).
struct IrradianceStats {
  std::size_t leaves = 0;
  float mean = 0.0f, max = 0.0f;
};

// The entity with the IndirectTransport settings.
struct TransportSummary {
  bool baked = false;
  std::uint32_t patches = 0, leaves = 0, finest_level = 0, terms = 0;
  float refinement_threshold = 0.0f, last_term_ratio = 0.0f;
  bool converged = false;
  std::uint64_t links = 0, direct_coefficients = 0, global_coefficients = 0, bytes = 0;
  std::size_t receivers = 0;        // meshes with IndirectReceiver
  std::size_t dynamic_lights = 0;   // enabled DynamicLights
  std::size_t fixed_lights = 0;     // of them, those that do not move (their bounce baked)
  bool moving_lights = true;        // the bake kept the operator (TransportData::moving_lights)
  bool has_lightmap = false;        // the system has written one
  std::uint32_t kept_coefficients = 0;  // significant direct coefficients of its last update
  IrradianceStats direct, indirect;     // over every leaf, of its last update
};
// NotFound when the entity has no IndirectTransport. Cost: O(leaves + entities).
Result<TransportSummary> transport_summary(World& world, Entity e);

// A mesh with IndirectReceiver: its share of the baked patches (by its entity key, as the bake
// names them) and of the lightmap.
struct ReceiverSummary {
  bool baked = false;  // some transport entity holds baked data
  std::uint32_t patches = 0, leaves = 0;
  float area = 0.0f;   // m^2, of its patches' rectangles
  IrradianceStats direct, indirect;
};
// NotFound when the entity has no IndirectReceiver. Cost: O(patches + its leaves).
Result<ReceiverSummary> receiver_summary(World& world, Entity e);

// Dragging a light in the viewport: where world point `point` goes when the pointer moves from
// pixel `from` to pixel `to` of a viewport of `size` pixels, moving in the plane through `point`
// that faces the camera (a point under the pointer stays under it). `point` unchanged when either
// ray misses that plane. O(1).
glm::vec3 drag_in_view_plane(const CameraView& camera, glm::vec3 point, glm::vec2 from, glm::vec2 to, glm::vec2 size);
// Moves entity `e` (with a Transform) so that its world position is `position`: its local
// translation, through its parent's world matrix when it has one; rotation and scale kept. Patched,
// so that the systems see the move (the indirect transport updates the bounce light). O(depth).
void move_to(World& world, Entity e, glm::vec3 position);

}  // namespace penumbra::editor
