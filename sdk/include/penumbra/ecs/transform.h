// Local and world transforms and the parent/child hierarchy.
//
// An entity's world matrix is its parent's world matrix times its local matrix (Transform). The
// hierarchy is stored twice, kept consistent by set_parent(): Parent on the child, Children on
// the parent. An entity whose parent is missing, stale or has no Transform is a root (its world
// matrix is its local one).
#pragma once

#include <vector>

#include <glm/ext/quaternion_float.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "penumbra/ecs/world.h"

namespace penumbra {

// Local transform relative to the parent: scale, then rotate, then translate (glTF TRS).
struct Transform {
  glm::vec3 translation{0.0f};
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // w, x, y, z
  glm::vec3 scale{1.0f};

  glm::mat4 matrix() const;  // T * R * S
};

// Local-to-world matrix, written by update_world_transforms().
struct WorldTransform {
  glm::mat4 matrix{1.0f};
};

struct Parent {
  Entity entity;
};

struct Children {
  std::vector<Entity> entities;  // in attachment order
};

// Attaches `child` under `parent` (Entity::null() detaches it), updating Parent and both Children
// lists, and marks the child's Transform changed so its world matrix is recomputed. Returns false
// and changes nothing when a handle is stale or the link would make a cycle (parent == child or
// parent below child). Cost: O(siblings) for a child without children (a hierarchy built top-down),
// else O(depth of parent + siblings).
bool set_parent(World& world, Entity child, Entity parent);

// Destroys `root` and every entity below it, and removes root from its parent's Children.
// A stale handle is ignored. Cost: O(size of the subtree).
void destroy_hierarchy(World& world, Entity root);

// Recomputes WorldTransform = parent world * local for the entities whose Transform changed, or
// whose parent's WorldTransform changed, since the previous call (adding WorldTransform where
// missing); untouched subtrees keep their matrices and change ticks. Advances the world's tick.
// Cost: one visit per entity with a Transform, one matrix product per recomputed entity.
void update_world_transforms(World& world);

// Registers the same pass as system "transforms" in Phase::Transform (reads Transform, Parent,
// Children; writes WorldTransform). Its change tracking uses the system's last-run tick.
void register_transform_systems(World& world);

}  // namespace penumbra
