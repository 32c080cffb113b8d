// The runtime half of skinned pose-AO: PoseAOSystem writes each character's per-vertex AO (into
// VertexAO, scene/components.h) every frame its pose changed; loading baked data; default
// components; registration.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/pbake.h"
#include "penumbra/ecs/world.h"
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

// Registers the "poseao" baker (one PSAO chunk per SkinnedPoseAO entity with Mesh and Skin, in
// entity order; the baked data, as read back from its chunk, is attached to the components) and
// the system above. The one call the tool and games make.
void register_pose_ao(World& world);

// Attaches the PSAO chunks of `file` to the SkinnedPoseAO components of the same entity index.
// Fails with InvalidInput for a corrupt chunk, and with NotFound naming the index when the entity
// has no SkinnedPoseAO or its mesh has another vertex count (re-bake the scene).
Status attach_pose_ao(World& world, const BakeFile& file);

// Gives every skinned mesh (Mesh with joints and weights, Skin) without a SkinnedPoseAO one with
// the preset's settings. Returns how many were added.
std::size_t add_default_pose_ao(World& world, Preset preset);

}  // namespace penumbra
