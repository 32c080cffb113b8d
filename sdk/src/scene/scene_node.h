// The built-in scenes' one way to make a node (internal to the scene module).
#pragma once

#include <string>
#include <utility>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::scene_detail {

// An entity named `name` with `transform`, under `parent` (null: a root entity).
inline Entity add_node(World& world, Entity parent, std::string name, const Transform& transform) {
  const Entity e = world.create();
  world.add<Name>(e, Name{std::move(name)});
  world.add<Transform>(e, transform);
  if (parent) set_parent(world, e, parent);
  return e;
}

}  // namespace penumbra::scene_detail
