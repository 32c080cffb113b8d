// What a game calls: the runtime half of every lighting module (no Embree, no glTF importer).
//
//   World world;
//   register_lighting(world);                        // once
//   ... build or import the scene ...
//   auto file = read_bake_file("level.pbake");       // penumbra/core/pbake.h
//   if (file) attach_bake(world, *file);             // baked data onto the components
//   world.update(dt);                                // every frame
#pragma once

#include <span>
#include <string_view>
#include <vector>

#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/module.h"

namespace penumbra {

// The SDK's modules (sdk/src/runtime/modules.inc), in registration order.
std::span<const LightingModule* const> lighting_modules();
// The module named `name`, or nullptr.
const LightingModule* find_lighting_module(std::string_view name);
// The module whose chunk type `type` is, or nullptr.
const LightingModule* lighting_module_for_chunk(std::uint32_t type);

// Registers the scene systems (animation, transforms, skinning) and every module's runtime
// systems with `world`. Call once per World, before the first update.
void register_lighting(World& world);

// Turns every AuthoredLighting (a glTF node's PENUMBRA_lighting, scene/components.h) into the
// modules' components, by their field lists: each declared component is added (on the node's
// entity, or on each of its mesh entities for ComponentInfo::on_mesh), set to its preset when one
// is named, then given the declared fields; the AuthoredLighting is removed. InvalidInput naming
// the file, the node, the component and the field (an unknown component, field or preset, a
// value of the wrong form or out of range, a per-mesh component on a node without a mesh); the
// components applied before the error stay. Cost: O(declared fields).
Status apply_authored_lighting(World& world);

// The inverse, for writing a glTF: the authorable components of `node` and of its `meshes` (the
// first mesh that has a per-mesh component speaks for the node), each as the defaults or a preset
// (whichever leaves fewer) and the settable fields that differ from it.
// apply_authored_lighting of the result rebuilds them exactly. Cost: O(components x fields).
std::vector<AuthoredComponent> authored_components(const World& world, Entity node, std::span<const Entity> meshes);

// What save_gltf (import/gltf.h) needs to write a World back to the glTF it was imported from: per
// imported node (GltfNode) its Transform (unless a clip animates it: the World holds the pose, not
// the rest transform), its Light and its authored_components (with the node's mesh children); the
// imported nodes (GltfScene) whose entities are gone, as removed; and as added nodes, the entities
// below the file's root entity that the file did not have and that are not a node's mesh
// primitives (an entity with a Mesh and neither GltfNode nor GltfNodeCopy): created ones, and
// copies (GltfNodeCopy), which take their node's mesh. Entities outside the file's root (a
// viewer's default light) are not written. InvalidArgument, naming the entity, for what a glTF
// cannot hold: a node with two copies of one mesh primitive (duplicate the node instead), a skin
// one of whose joints was deleted.
// Cost: O(entities).
Result<GltfEdits> gltf_edits(World& world);

// apply_authored_lighting, then every module's add_defaults (module.h) in the modules' order
// (modules skip entities that already have their components), then one world.update(0) so that
// the new components' transforms are current. An authored declaration's error returns at once;
// a module that fails does not stop the others, and the first module error is returned.
Status add_default_lighting(World& world, Preset preset, bool authored);

// Attaches every chunk of `file` to the entities its keys name, through the module that owns the
// chunk's type (chunks of types no linked module owns are skipped with a logged warning). Fails at
// the first chunk that is corrupt or names a key this World lacks (the error names the chunk and
// the key); the chunks before it stay attached. A part of a sharded bake (kShardManifestChunk) is
// refused before any chunk, with InvalidInput saying to merge the parts. Cost: O(entities) to index the keys, then each
// module's attach.
Status attach_bake(World& world, const BakeFile& file);

}  // namespace penumbra
