// The runtime half of skinned pose-AO: PoseAOSystem writes each character's per-vertex AO every
// frame its pose changed; loading baked data; default components; registration.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/pbake.h"
#include "penumbra/ecs/world.h"
#include "penumbra/pose_ao/pose_ao.h"

namespace penumbra {

// Output component, on every skinned mesh with baked SkinnedPoseAO data: ao[v] in [0, 1] (1 =
// open) for mesh vertex v, in the current pose. The renderer uploads it as a per-vertex attribute
// (or uses the GPU layout of pose_ao.h instead). Written by the system with World::patch.
struct PoseAOValues {
  std::vector<float> ao;
  std::uint64_t updated_tick = 0;  // the World tick of the last update
};

// PoseAOSystem's step: for every entity with SkinnedPoseAO (with data) and SkinPose whose SkinPose
// or SkinnedPoseAO changed after tick `since`, computes the pose parameters once (pose_features)
// and the AO of every vertex (evaluate_pose_ao) into PoseAOValues (added when missing). Entities
// whose data does not match their SkinPose (another joint count) are skipped. Entities without the
// component cost nothing. Returns the number of meshes updated.
// Cost: O(joints) + about (1 + 9 k) multiply-adds per vertex of each updated mesh.
std::size_t update_pose_ao(World& world, std::uint64_t since);

// Registers system "pose-ao" in Phase::Lighting (reads SkinPose, SkinnedPoseAO; writes
// PoseAOValues), calling update_pose_ao with the system's last-run tick. Run after "skinning".
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
