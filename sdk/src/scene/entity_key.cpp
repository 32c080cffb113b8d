// Stable authoring keys (see entity_key.h).
#include "penumbra/scene/entity_key.h"

#include <vector>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

Entity parent_of(const World& world, Entity e) {
  const Parent* p = world.try_get<Parent>(e);
  return p != nullptr && world.alive(p->entity) ? p->entity : Entity::null();
}

// Builds keys with the sibling counts of each parent computed once and the keys of ancestors
// remembered: O(entities) for a whole World, iterative (no recursion on deep hierarchies).
class KeyBuilder {
 public:
  explicit KeyBuilder(const World& world) : world_(world) {}

  std::string key(Entity e) {
    if (!world_.alive(e)) return {};
    if (auto it = memo_.find(e.index); it != memo_.end()) return it->second;
    // The chain from e up to the first ancestor whose key prefix is known: one with an EntityKey,
    // a remembered one, or the root (left out unless it is e itself).
    std::vector<Entity> chain{e};
    std::string prefix;
    bool have_prefix = false;
    for (Entity cur = e;;) {
      if (const EntityKey* k = world_.try_get<EntityKey>(cur)) {
        prefix = k->value;
        chain.pop_back();
        have_prefix = true;
        break;
      }
      const Entity parent = parent_of(world_, cur);
      if (!parent) break;  // cur is the root
      if (auto it = memo_.find(parent.index); it != memo_.end() && !is_root(parent)) {
        prefix = it->second;
        have_prefix = true;
        break;
      }
      if (is_root(parent) && !world_.has<EntityKey>(parent)) break;
      chain.push_back(parent);
      cur = parent;
    }
    // Walk back down, remembering each key.
    std::string k = prefix;
    bool valid = !have_prefix || !prefix.empty();
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const std::string s = segment(*it);
      if (s.empty()) valid = false;
      k = k.empty() ? s : k + "/" + s;
      if (valid) memo_[it->index] = k;
    }
    return valid ? k : std::string();
  }

 private:
  bool is_root(Entity e) const { return !parent_of(world_, e); }

  // The entity's Name, with "[k]" when k earlier siblings share it; empty without a name.
  std::string segment(Entity e) {
    const Name* name = world_.try_get<Name>(e);
    if (name == nullptr || name->value.empty()) return {};
    const Entity parent = parent_of(world_, e);
    if (!parent) return name->value;
    auto [counts, fresh] = earlier_.try_emplace(parent.index);
    if (fresh) {
      std::unordered_map<std::string, int> seen;
      if (const Children* siblings = world_.try_get<Children>(parent))
        for (Entity s : siblings->entities)
          if (const Name* n = world_.try_get<Name>(s); n != nullptr && world_.alive(s))
            counts->second[s.index] = seen[n->value]++;
    }
    const auto it = counts->second.find(e.index);
    const int k = it == counts->second.end() ? 0 : it->second;
    return k == 0 ? name->value : name->value + "[" + std::to_string(k) + "]";
  }

  const World& world_;
  std::unordered_map<std::uint32_t, std::string> memo_;
  std::unordered_map<std::uint32_t, std::unordered_map<std::uint32_t, int>> earlier_;  // parent -> child -> k
};

}  // namespace

std::string entity_key(const World& world, Entity e) { return KeyBuilder(world).key(e); }

EntityKeys EntityKeys::build(World& world) {
  EntityKeys keys;
  KeyBuilder builder(world);
  std::vector<Entity> keyed = world.view<Name>().sorted_entities();
  for (Entity e : world.view<EntityKey>().sorted_entities())
    if (!world.has<Name>(e)) keyed.push_back(e);
  for (Entity e : keyed) {
    std::string key = builder.key(e);
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
