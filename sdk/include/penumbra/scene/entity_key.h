// Stable authoring keys: how baked data names the entity it belongs to, so that a bake loads into
// a World built in another order (an engine's own objects, a re-imported file, a streamed level).
//
// An entity's key is its EntityKey when the host set one, else its name path: the Name of each
// ancestor below the scene root, then its own, joined by '/'. The root itself, whose name is the
// file or built-in scene name, is left out unless the host gave it an EntityKey, which then
// prefixes every key below it (so two streamed levels with the same node names get distinct keys);
// an ancestor's EntityKey likewise prefixes its subtree; an entity without a parent is its own
// Name. A name that several siblings share gets "[k]" appended for the k-th of them (k >= 1, in
// Children order). An entity with no name on that path has no key (empty): a baker rejects it,
// naming it and asking for a name or an EntityKey.
//
// Limits: names are not escaped, so a name holding '/' can make two paths equal (reported as a
// shared key); removing or reordering same-named siblings renumbers their "[k]" (a bake then
// attaches to the wrong one or fails on its vertex count: set EntityKeys where that matters).
#pragma once

#include <string>
#include <string_view>
#include <unordered_map>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra {

// A key the host sets for an entity (overrides the name path). Must be unique in the World.
struct EntityKey {
  std::string value;
};

// The key of `e` as above; empty when it has none. Cost: O(depth x siblings); use EntityKeys for
// many entities.
std::string entity_key(const World& world, Entity e);

// Every keyed entity of a World, by key: what attaching a bake looks entities up in.
class EntityKeys {
 public:
  // Indexes every live entity with a Name or an EntityKey. Cost: O(entities) key builds (each
  // parent's sibling names counted once, ancestors' keys remembered).
  static EntityKeys build(World& world);

  // The entity of `key`. NotFound naming the key and `context` (e.g. "chunk 'PRBG' (probe-grid)")
  // when no entity has it, InvalidInput when several do (give them distinct names or EntityKeys).
  Result<Entity> find(std::string_view key, std::string_view context) const;

 private:
  std::unordered_map<std::string, Entity> entities_;
  std::unordered_map<std::string, int> duplicates_;  // keys held by more than one entity: how many
};

}  // namespace penumbra
