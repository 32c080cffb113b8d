// Subtrees taken out, put back and copied (subtree.h).
#include "subtree.h"

#include <algorithm>
#include <cctype>
#include <set>
#include <unordered_map>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {

namespace {

struct EntityHash {
  std::size_t operator()(Entity e) const { return (std::size_t{e.generation} << 32) ^ e.index; }
};
using Map = std::unordered_map<Entity, Entity, EntityHash>;

Map to_map(const Remap& remap) {
  Map m;
  for (const auto& [from, to] : remap) m.emplace(from, to);
  return m;
}

// Rewrites the Skin joints and Animator clip targets of `owners` (all of the world's when empty)
// that name a remapped entity.
void remap_references(World& world, const Map& map, const std::vector<Entity>& owners) {
  const auto mapped = [&](Entity e) {
    const auto it = map.find(e);
    return it == map.end() ? e : it->second;
  };
  const auto fix = [&](Entity owner) {
    if (const Skin* skin = world.try_get<Skin>(owner)) {
      if (std::any_of(skin->joints.begin(), skin->joints.end(), [&](Entity j) { return map.contains(j); })) {
        Skin& s = world.patch<Skin>(owner);
        for (Entity& j : s.joints) j = mapped(j);
      }
    }
    if (const Animator* animator = world.try_get<Animator>(owner); animator && animator->clips) {
      bool touched = false;
      for (const AnimationClip& c : *animator->clips)
        touched = touched || std::any_of(c.targets.begin(), c.targets.end(), [&](Entity t) { return map.contains(t); });
      if (touched) {
        auto clips = std::make_shared<std::vector<AnimationClip>>(*animator->clips);
        for (AnimationClip& c : *clips)
          for (Entity& t : c.targets) t = mapped(t);
        world.patch<Animator>(owner).clips = std::move(clips);
      }
    }
  };
  if (!owners.empty()) {
    for (Entity e : owners) fix(e);
    return;
  }
  std::vector<Entity> all;
  world.each<Skin>([&](Entity e, Skin&) { all.push_back(e); });
  world.each<Animator>([&](Entity e, Animator&) { all.push_back(e); });
  for (Entity e : all) fix(e);
}

// New entities for `count` copies, each with the components `copy(i, new entity)` gives it, then
// linked: entity i under entity parent[i] in order, the root under `root_parent` at `position`.
Remap build(World& world, const std::vector<Entity>& old_handles, const std::vector<int>& parent,
            Entity root_parent, std::size_t position, const std::function<void(std::size_t, Entity)>& copy) {
  Remap remap;
  for (std::size_t i = 0; i < old_handles.size(); ++i) {
    const Entity e = world.create();
    copy(i, e);
    // The copies' links name the old entities: rebuilt below.
    world.remove<Parent>(e);
    world.remove<Children>(e);
    remap.emplace_back(old_handles[i], e);
  }
  for (std::size_t i = 1; i < remap.size(); ++i) set_parent(world, remap[i].second, remap[parent[i]].second);
  const Entity root = remap.front().second;
  if (world.alive(root_parent) && set_parent(world, root, root_parent)) {
    std::vector<Entity>& siblings = world.patch<Children>(root_parent).entities;
    const auto at = siblings.begin() + static_cast<std::ptrdiff_t>(std::min(position, siblings.size() - 1));
    std::rotate(at, siblings.end() - 1, siblings.end());
  }
  return remap;
}

Entity parent_of(World& world, Entity e) {
  const Parent* p = world.try_get<Parent>(e);
  return p && world.alive(p->entity) ? p->entity : Entity::null();
}

}  // namespace

std::vector<Entity> subtree_of(World& world, Entity root) {
  std::vector<Entity> out;
  if (!world.alive(root)) return out;
  out.push_back(root);
  for (std::size_t i = 0; i < out.size(); ++i)
    if (const Children* kids = world.try_get<Children>(out[i]))
      for (Entity k : kids->entities)
        if (world.alive(k)) out.push_back(k);
  return out;
}

std::unique_ptr<HeldSubtree> take_out(World& world, Entity root) {
  auto held = std::make_unique<HeldSubtree>();
  held->handles = subtree_of(world, root);
  Map index;
  for (std::size_t i = 0; i < held->handles.size(); ++i) index.emplace(held->handles[i], Entity{static_cast<std::uint32_t>(i), 0});
  for (std::size_t i = 0; i < held->handles.size(); ++i) {
    const Entity e = held->handles[i];
    const Entity copy = held->world.create();
    held->skipped += world.copy_components(e, held->world, copy);
    held->held.push_back(copy);
    const auto p = index.find(parent_of(world, e));
    held->parent.push_back(i == 0 || p == index.end() ? -1 : static_cast<int>(p->second.index));
  }
  held->root_parent = parent_of(world, root);
  if (const Children* siblings = world.try_get<Children>(held->root_parent)) {
    const auto it = std::find(siblings->entities.begin(), siblings->entities.end(), root);
    held->position = static_cast<std::size_t>(it - siblings->entities.begin());
  }
  destroy_hierarchy(world, root);
  return held;
}

Remap put_back(World& world, HeldSubtree& held) {
  const Remap remap = build(world, held.handles, held.parent, held.root_parent, held.position,
                            [&](std::size_t i, Entity e) { held.world.copy_components(held.held[i], world, e); });
  remap_references(world, to_map(remap), {});
  return remap;
}

Remap copy_subtree(World& world, Entity root, const std::string& name) {
  const std::vector<Entity> originals = subtree_of(world, root);
  Map index;
  for (std::size_t i = 0; i < originals.size(); ++i) index.emplace(originals[i], Entity{static_cast<std::uint32_t>(i), 0});
  std::vector<int> parent;
  for (std::size_t i = 0; i < originals.size(); ++i) {
    const auto p = index.find(parent_of(world, originals[i]));
    parent.push_back(i == 0 || p == index.end() ? -1 : static_cast<int>(p->second.index));
  }
  const Entity root_parent = parent_of(world, root);
  std::size_t position = 0;
  if (const Children* siblings = world.try_get<Children>(root_parent))
    position = static_cast<std::size_t>(std::find(siblings->entities.begin(), siblings->entities.end(), root) -
                                        siblings->entities.begin()) + 1;
  const Remap remap = build(world, originals, parent, root_parent, position, [&](std::size_t i, Entity e) {
    world.copy_components(originals[i], world, e);
    if (const GltfNode* node = world.try_get<GltfNode>(e)) {
      const GltfNodeCopy copy{node->index};
      world.remove<GltfNode>(e);
      world.add<GltfNodeCopy>(e, copy);
    }
    world.remove<GltfScene>(e);
    world.remove<EntityKey>(e);
  });
  world.add<Name>(remap.front().second, name);
  std::vector<Entity> copies;
  for (const auto& [from, to] : remap) copies.push_back(to);
  remap_references(world, to_map(remap), copies);
  return remap;
}

std::string copy_name(World& world, Entity e) {
  const Name* own = world.try_get<Name>(e);
  std::string base = own ? own->value : "entity";
  // "crate (2)" copies as "crate (3)", not "crate (2) (2)".
  if (const auto open = base.rfind(" ("); open != std::string::npos && base.back() == ')' && open + 3 < base.size() &&
      std::all_of(base.begin() + static_cast<std::ptrdiff_t>(open) + 2, base.end() - 1,
                  [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }))
    base.resize(open);
  std::set<std::string> taken;
  const Entity parent = parent_of(world, e);
  if (const Children* siblings = world.try_get<Children>(parent)) {
    for (Entity s : siblings->entities)
      if (const Name* n = world.try_get<Name>(s)) taken.insert(n->value);
  } else {
    world.each<Name>([&](Entity s, Name& n) {
      if (!parent_of(world, s)) taken.insert(n.value);
    });
  }
  for (int k = 2;; ++k) {
    std::string name = base + " (" + std::to_string(k) + ")";
    if (!taken.contains(name)) return name;
  }
}

}  // namespace penumbra::editor
