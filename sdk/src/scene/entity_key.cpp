// Stable authoring keys (see entity_key.h).
#include "penumbra/scene/entity_key.h"

#include <algorithm>
#include <vector>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

// The entity's Name, with "[k]" when k earlier siblings share it; empty without a name.
std::string segment(const World& world, Entity e, Entity parent) {
  const Name* name = world.try_get<Name>(e);
  if (name == nullptr || name->value.empty()) return {};
  int earlier = 0;
  if (const Children* siblings = parent ? world.try_get<Children>(parent) : nullptr) {
    for (Entity s : siblings->entities) {
      if (s == e) break;
      const Name* other = world.try_get<Name>(s);
      if (other != nullptr && other->value == name->value) ++earlier;
    }
  }
  return earlier == 0 ? name->value : name->value + "[" + std::to_string(earlier) + "]";
}

Entity parent_of(const World& world, Entity e) {
  const Parent* p = world.try_get<Parent>(e);
  return p != nullptr && world.alive(p->entity) ? p->entity : Entity::null();
}

}  // namespace

std::string entity_key(const World& world, Entity e) {
  if (!world.alive(e)) return {};
  if (const EntityKey* key = world.try_get<EntityKey>(e)) return key->value;
  // Walk up to the root, which is left out unless the entity is the root itself.
  std::vector<std::string> path;
  for (Entity cur = e; cur;) {
    const Entity parent = parent_of(world, cur);
    if (!parent && cur != e) break;
    std::string s = segment(world, cur, parent);
    if (s.empty()) return {};
    path.push_back(std::move(s));
    cur = parent;
  }
  std::string out;
  for (auto it = path.rbegin(); it != path.rend(); ++it) out += (out.empty() ? "" : "/") + *it;
  return out;
}

EntityKeys EntityKeys::build(World& world) {
  EntityKeys keys;
  std::vector<Entity> keyed = world.view<Name>().sorted_entities();
  for (Entity e : world.view<EntityKey>().sorted_entities())
    if (!world.has<Name>(e)) keyed.push_back(e);
  for (Entity e : keyed) {
    std::string key = entity_key(world, e);
    if (key.empty()) continue;
    if (auto [it, inserted] = keys.entities_.try_emplace(key, e); !inserted) {
      int& n = keys.duplicates_[key];
      n = n == 0 ? 2 : n + 1;
    }
  }
  return keys;
}

Result<Entity> EntityKeys::find(std::string_view key, std::string_view context) const {
  const std::string k(key);
  if (auto d = duplicates_.find(k); d != duplicates_.end())
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": " + std::to_string(d->second) +
                                                   " entities have the key '" + k +
                                                   "'; give them distinct names or EntityKeys, then re-bake");
  auto it = entities_.find(k);
  if (it == entities_.end())
    return make_error(ErrorCode::NotFound, std::string(context) + ": no entity has the key '" + k +
                                               "' in this World (renamed, moved or removed since the bake?); "
                                               "re-bake the scene");
  return it->second;
}

}  // namespace penumbra
