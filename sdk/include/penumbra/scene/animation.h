// Keyframe animation (glTF 2.0 sampler semantics) and skinning.
//
// Sampling follows the glTF 2.0 specification, Appendix C "Interpolation": LINEAR (lerp; slerp
// for rotations), STEP, CUBICSPLINE (cubic Hermite with tangents scaled by the key interval);
// rotations are returned normalised. Before the first key the first value holds, after the last
// the last value holds.
#pragma once

#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "penumbra/ecs/world.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// Value of `channel` at time `t` seconds: xyz for translation/scale, quaternion xyzw for rotation.
// Precondition: channel.times non-empty and increasing; values sized per the interpolation
// (3 per key for CubicSpline). Cost: O(log keys). Thread-safe.
glm::vec4 sample_channel(const AnimationChannel& channel, float t);

// Maps a playback time onto [0, duration]: wraps when looping, clamps otherwise.
float clip_time(float t, float duration, bool loop);

// Writes the pose of `clip` at time `t` into the Transforms of its targets (via World::patch, so
// change tracking sees them). Targets that are dead or lack a Transform are skipped.
void apply_clip(World& world, const AnimationClip& clip, float t);

// The animation system's step: advances each playing Animator by dt * speed (wrapping or
// clamping; a clamped clip stops playing at its end) and applies its current clip.
void update_animators(World& world, float dt);

// The skinning system's step: for each entity with Skin and WorldTransform, writes
// SkinPose::joint_matrices[j] = inverse(entity world) * joint world * inverse_bind[j].
// Run after the transform system.
void update_skin_poses(World& world);

// CPU linear blend skinning into the mesh's local frame: out[i] = sum_k w_k M[j_k] p_i.
// Precondition: mesh has joints/weights, every joint index < pose.joint_matrices.size().
// Cost: O(vertices). Thread-safe (reads only its arguments).
void skin_positions(const MeshData& mesh, const SkinPose& pose, std::vector<glm::vec3>& out);
// Same for normals (blended matrix's inverse transpose, renormalised); empty if the mesh has none.
void skin_normals(const MeshData& mesh, const SkinPose& pose, std::vector<glm::vec3>& out);

// World-space box of every Mesh with data and a WorldTransform as posed now: a skinned mesh (with
// a SkinPose whose matrices cover its joints) by its skinned vertices, any other by its box's
// corners. This is what a camera must frame: a skinned mesh's node transform does not place its
// vertices (an armature scaled by 0.01 shrinks the node's box, not the character). Empty when
// the world has no such mesh. With a `root`, only the meshes of root's subtree (root and its
// descendants). Run after the skinning system. Cost: O(skinned vertices + meshes x depth).
Aabb posed_bounds(World& world, Entity root = Entity::null());

// The skinned meshes of `mesh`'s character, those that occlude it: every Mesh + Skin entity whose
// skin shares a joint entity with `mesh`'s skin (one skeleton, several meshes: a body, its armour,
// its hair), `mesh` first, then the others in entity order; left out are entities of the same
// MeshData and other levels of detail (a name, the entity's or its mesh's, with "LOD" and a digit
// other than `mesh`'s), which lie on the same surface. Only `mesh` when it has no Skin. Cost:
// O(skinned meshes x joints).
std::vector<Entity> character_meshes(World& world, Entity mesh);

// Registers, in order: "animation" (Phase::Animation), the ecs transform systems
// (register_transform_systems, Phase::Transform) and "skinning" (Phase::Transform, after the
// transforms). Call once per World instead of register_transform_systems.
void register_scene_systems(World& world);

}  // namespace penumbra
