// The runtime half of skinned pose-AO: PoseAOSystem writes each character's per-vertex AO (into
// VertexAO, scene/components.h) every frame its pose changed; default components; the module
// descriptor (attaching a PSAO chunk sets the SkinnedPoseAO::data of the entity its key names;
// NotFound when that entity's mesh has another vertex count).
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/ecs/world.h"
#include "penumbra/lighting/module.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// PoseAOSystem's step: for every entity with SkinnedPoseAO (with data) and SkinPose whose SkinPose
// or SkinnedPoseAO changed after tick `since`, computes the pose parameters once (pose_features)
// and the AO of every vertex (evaluate_pose_ao) into the entity's VertexAO (scene/components.h;
// added when missing, else written with World::patch, so the renderer re-uploads that mesh's AO
// attribute only in frames whose pose changed). Entities whose data does not match their SkinPose
// (another joint count) are skipped. Entities without the component cost nothing. Returns the number of meshes updated.
// Cost: O(joints) + about (1 + 9 k) multiply-adds per vertex of each updated mesh.
std::size_t update_pose_ao(World& world, std::uint64_t since);

// Registers system "pose-ao" in Phase::Lighting (reads SkinPose, SkinnedPoseAO; writes
// VertexAO), calling update_pose_ao with the system's last-run tick. Run after "skinning".
void register_pose_ao_system(World& world);

// The entities the pose-AO bake covers, in entity-index order: SkinnedPoseAO and WorldTransform
// on a Mesh with joints and weights for every vertex, and a Skin.
std::vector<Entity> pose_ao_meshes(World& world);

// Gives every skinned mesh (Mesh with joints and weights, Skin) without a SkinnedPoseAO one with
// the preset's settings. Returns how many were added.
std::size_t add_default_pose_ao(World& world, Preset preset);

// Instances of one character share one bake (pose-AO is self-occlusion: it does not depend on
// where the character stands): gives each skinned mesh with a SkinnedPoseAO below `to` in `to_world`
// the baked data of the skinned mesh at the same place below `from` in `from_world` (both depth
// first in Children order; the worlds may be the same). Pairs whose vertex or joint counts differ,
// or whose source is not baked, are skipped. Returns the meshes given data. Cost: O(entities below
// both roots), no copy of the data.
std::size_t share_pose_ao(const World& from_world, Entity from, World& to_world, Entity to);

const LightingModule& pose_ao_module();

}  // namespace penumbra
