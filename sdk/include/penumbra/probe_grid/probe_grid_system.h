// The runtime half of the probe grid: the system that lights ProbeLit entities, the default grid
// for a scene without one, and the module descriptor (attaching a PRBG chunk sets the
// IrradianceProbeGrid::data of the entity its key names, with World::patch so receivers update).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "penumbra/ecs/world.h"
#include "penumbra/lighting/module.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra {

// Where a receiver takes its lighting: the centre of its Mesh's bounds through its WorldTransform
// when it has a mesh with bounds (a character's middle rather than its feet; for a skinned mesh the
// bind pose's bounds), else its origin. Precondition: `e` has a WorldTransform. Cost: O(1).
// Thread-safe for concurrent reads of the World.
glm::vec3 probe_lit_position(const World& world, Entity e);

// A baked grid as the runtime blends it: its data, priority, entity index and blend distance
// (IrradianceProbeGrid::blend_distance, or the smallest node spacing when that is 0).
struct BlendedProbeGrid {
  std::shared_ptr<const ProbeGridData> data;
  int priority = 0;
  std::uint32_t index = 0;
  float blend = 1.0f;  // metres
};
// The World's grids with data, by descending priority, then entity index: the order of the blend.
// Cost: O(grids log grids).
std::vector<BlendedProbeGrid> blended_probe_grids(World& world);
// Grid g's fade at world point x: 0 outside its box; inside, clamp(distance to its border / blend
// distance, 1e-4, 1), so a point on the border still counts as covered. Cost: O(1).
float probe_grid_coverage(const BlendedProbeGrid& g, glm::vec3 x);
// The blend's weight of each of `grids` (in blended_probe_grids order) at x, in `weights`: each
// covering grid takes its fade of what the grids before it left, and the last covering grid all
// that is left (the weights sum to 1). Returns false, all weights 0, where no grid covers x (the
// renderer then takes the first grid's clamped lookup). Cost: O(grids).
bool probe_grid_weights(std::span<const BlendedProbeGrid> grids, glm::vec3 x, std::vector<float>& weights);

// Gives every ProbeLit entity with a WorldTransform its irradiance at probe_lit_position, but only
// the entities whose WorldTransform, ProbeLit or Mesh changed after tick `since`, or all when any
// grid (IrradianceProbeGrid or its WorldTransform) changed or was removed after `since`. Where
// grids overlap they are blended by probe_grid_weights (the renderer's per-pixel blend). Writes
// ProbeLit with World::patch (outside a system, advance the World's tick afterwards). Returns the
// number of receivers updated.
// Cost: O(grids + updated receivers x covering grids x 8 nodes).
std::size_t update_probe_lighting(World& world, std::uint64_t since);

// Registers system "probe-grid" in Phase::Lighting (reads WorldTransform, IrradianceProbeGrid;
// writes ProbeLit), calling update_probe_lighting with the system's last-run tick.
void register_probe_grid_system(World& world);

// Gives a scene without an IrradianceProbeGrid one: an entity named "probe grid" whose box is the static geometry's
// bounds inset by 2% (at least 1 cm) on every side, with the preset's settings (Indirect lighting,
// for the SDK's renderer, which draws direct light itself). Returns the
// existing grid entity when there is one, and InvalidInput when the World has no static geometry.
Result<Entity> add_default_probe_grid(World& world, Preset preset);

// Sizes the IrradianceProbeGrid of `e` to what it is added to (ComponentInfo::fit): the posed
// bounds of the meshes of e's subtree grown by 10% of their size on every side (a grid around an
// object covers its surroundings); for an entity without meshes, the static geometry's bounds
// inset as add_default_probe_grid does (else every mesh's). Nothing when the World has no mesh.
// Cost: O(meshes x depth + skinned vertices).
void fit_probe_grid(World& world, Entity e);

const LightingModule& probe_grid_module();

}  // namespace penumbra
