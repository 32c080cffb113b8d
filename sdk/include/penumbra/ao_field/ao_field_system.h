// The runtime half of ambient occlusion fields: the system that gives AOFieldReceiver entities the
// combined occlusion of the casters near them, default casters and receivers, and the module
// descriptor (attaching an AOFC chunk sets the AOFieldCaster::data of the entity its key names).
#pragma once

#include <cstddef>
#include <cstdint>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/module.h"
#include "penumbra/lighting/settings.h"

namespace penumbra {

// Gives every AOFieldReceiver entity (Mode::Entity) with a WorldTransform the occlusion at its origin (normal:
// its receiver normal through the world matrix) from every baked caster (AOFieldCaster with data
// and a WorldTransform; not the receiver itself), combined by 1 - prod (1 - A_i). A caster is
// skipped for receivers at or beyond its falloff distance (r_far x its uniform scale from its
// field centre), so casters far from every receiver cost one distance test each. Updates only
// the receivers whose WorldTransform or AOFieldReceiver changed after tick `since`, or all of them
// when any caster (its component or WorldTransform) changed or the number of baked casters
// changed. Writes with World::patch. Returns the number of receivers updated.
// Each caster evaluates its receivers in range in one accumulate_open batch. Cost: O(casters x
// updated receivers) distance tests plus accumulate_open's ~15 ns per receiver and caster in
// range (RadialFit, AVX2).
std::size_t update_ao_field_receivers(World& world, std::uint64_t since);

// Registers system "ao-field" in Phase::Lighting (reads WorldTransform, AOFieldCaster; writes
// AOFieldReceiver), calling update_ao_field_receivers with the system's last-run tick.
void register_ao_field_system(World& world);

// Gives a scene made without lighting components (the built-in scenes) its AO fields: every rigid
// movable mesh (a Mesh with data and a WorldTransform, neither Static nor skinned, with no
// AOFieldCaster yet, whose world matrix passes validate_ao_field_caster) gets
// AOFieldCaster::preset(preset); every Static mesh gets a Surface receiver (the renderer's
// per-pixel pass) and every skinned mesh an Entity receiver (normal +Y: the walker's feet), unless
// they have an AOFieldReceiver. Returns the number of casters added. Cost: O(entities).
std::size_t add_default_ao_field_casters(World& world, Preset preset);

const LightingModule& ao_field_module();

}  // namespace penumbra
