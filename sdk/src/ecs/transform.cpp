// World transforms over the parent/child hierarchy, recomputed only where something changed.
#include "penumbra/ecs/transform.h"

#include <glm/gtc/quaternion.hpp>

namespace penumbra {

namespace {

// The tick of the last update_world_transforms() call made outside the system scheduler.
struct TransformClock {
  std::uint64_t last_run = 0;
};

// Propagates world matrices top-down from every root, recomputing an entity when its Transform
// changed after `since`, when its parent's WorldTransform changed after `since` (rewritten by this
// pass or by someone else), or when it has no WorldTransform yet.
void propagate(World& world, std::uint64_t since) {
  // Step 1: the roots (no usable parent).
  std::vector<Entity> roots;
  world.each<Transform>([&](Entity e, Transform&) {
    const Parent* parent = world.try_get<Parent>(e);
    if (!parent || !world.has<Transform>(parent->entity)) roots.push_back(e);
  });

  // Step 2: depth-first from each root with an explicit stack (hierarchies may be deep).
  struct Item {
    Entity entity;
    glm::mat4 parent_world;
    bool parent_changed;
  };
  std::vector<Item> stack;
  for (const Entity root : roots) {
    stack.push_back(Item{root, glm::mat4(1.0f), false});
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      const Entity e = item.entity;
      WorldTransform* wt = world.try_get<WorldTransform>(e);
      const bool recompute = item.parent_changed || !wt || world.changed_tick<Transform>(e) > since;
      glm::mat4 matrix;
      if (recompute) {
        matrix = item.parent_world * world.get<Transform>(e).matrix();
        if (wt)
          world.patch<WorldTransform>(e).matrix = matrix;
        else
          world.add<WorldTransform>(e, matrix);
      } else {
        matrix = wt->matrix;
      }
      const bool changed = world.changed_tick<WorldTransform>(e) > since;
      if (const Children* children = world.try_get<Children>(e)) {
        // Reverse push so that children are visited in attachment order.
        for (auto it = children->entities.rbegin(); it != children->entities.rend(); ++it)
          if (world.has<Transform>(*it)) stack.push_back(Item{*it, matrix, changed});
      }
    }
  }
}

bool is_ancestor_or_self(const World& world, Entity ancestor, Entity e) {
  for (Entity at = e; world.alive(at);) {
    if (at == ancestor) return true;
    const Parent* p = world.try_get<Parent>(at);
    if (!p) break;
    at = p->entity;
  }
  return false;
}

}  // namespace

glm::mat4 Transform::matrix() const {
  // T * R * S, composed directly: the columns of R scaled, then the translation.
  const glm::mat3 r = glm::mat3_cast(rotation);
  return glm::mat4(glm::vec4(r[0] * scale.x, 0.0f), glm::vec4(r[1] * scale.y, 0.0f),
                   glm::vec4(r[2] * scale.z, 0.0f), glm::vec4(translation, 1.0f));
}

bool set_parent(World& world, Entity child, Entity parent) {
  if (!world.alive(child) || (parent && !world.alive(parent))) return false;
  // A cycle needs `child` to be `parent` or above it, which a child without children cannot be:
  // building a hierarchy top-down then costs O(1) per link, not O(depth).
  const Children* descendants = world.try_get<Children>(child);
  const bool may_be_above = descendants != nullptr && !descendants->entities.empty();
  if (parent && (parent == child || (may_be_above && is_ancestor_or_self(world, child, parent)))) return false;

  // Detach from the previous parent's Children.
  if (const Parent* old = world.try_get<Parent>(child)) {
    if (old->entity == parent) return true;
    if (Children* siblings = world.try_get<Children>(old->entity)) std::erase(siblings->entities, child);
  }
  if (parent) {
    world.add<Parent>(child, parent);
    Children* children = world.try_get<Children>(parent);
    if (!children) children = &world.add<Children>(parent);
    children->entities.push_back(child);
  } else {
    world.remove<Parent>(child);
  }
  if (world.has<Transform>(child)) world.patch<Transform>(child);
  return true;
}

void destroy_hierarchy(World& world, Entity root) {
  if (!world.alive(root)) return;
  set_parent(world, root, Entity::null());
  // Collect the subtree first (depth-first), then destroy it.
  std::vector<Entity> subtree{root};
  for (std::size_t i = 0; i < subtree.size(); ++i)
    if (const Children* children = world.try_get<Children>(subtree[i]))
      for (const Entity child : children->entities)
        if (world.alive(child)) subtree.push_back(child);
  for (const Entity e : subtree) world.destroy(e);
}

void update_world_transforms(World& world) {
  TransformClock& clock = world.resource<TransformClock>();
  const std::uint64_t since = clock.last_run;
  clock.last_run = world.advance_tick();
  propagate(world, since);
  world.advance_tick();  // later writes are newer than this pass
}

void register_transform_systems(World& world) {
  SystemDesc desc;
  desc.name = "transforms";
  desc.phase = Phase::Transform;
  desc.reads = {component_id<Transform>(), component_id<Parent>(), component_id<Children>()};
  desc.writes = {component_id<WorldTransform>()};
  desc.run = [](World& w, const SystemContext& ctx) { propagate(w, ctx.last_run); };
  world.add_system(std::move(desc));
}

}  // namespace penumbra
