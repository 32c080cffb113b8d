// An entity and everything below it as a unit the editor can take out of a World, put back, and
// copy: what deleting, undoing a creation and duplicating are made of (undo.h records them).
// Components travel by World::copy_components, so every copyable component of every module goes
// along without the editor knowing it. Entity handles inside components are remapped where the
// editor knows them: Parent and Children, Skin::joints and the targets of Animator clips.
// Not thread-safe: the main thread's World only.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/ecs/world.h"

namespace penumbra::editor {

// A subtree out of its World: copies of its entities' components, in depth-first order.
struct HeldSubtree {
  World world;                      // holds the copies
  std::vector<Entity> held;         // entity i of the subtree in `world`; 0 is the root
  std::vector<int> parent;          // entity i's parent in the list; -1 for the root
  std::vector<Entity> handles;      // entity i's handle in the document when taken out
  Entity root_parent;               // the root's parent there (null: it was a root)
  std::size_t position = 0;         // the root's place among that parent's Children
  std::size_t skipped = 0;          // components that could not be copied (move-only types)
};

// The handle an entity had and the one it has now, after put_back or copy_subtree.
using Remap = std::vector<std::pair<Entity, Entity>>;

// The entities of `root`'s subtree, root first, depth-first in Children order. Empty for a stale
// handle. Cost: O(subtree).
std::vector<Entity> subtree_of(World& world, Entity root);

// Copies `root`'s subtree into a HeldSubtree, then destroys it (destroy_hierarchy). Precondition:
// world.alive(root). Cost: O(components of the subtree), each copied once.
std::unique_ptr<HeldSubtree> take_out(World& world, Entity root);

// Creates the held entities again with their components, each under its parent, the root under
// root_parent at its old place (or as a root when that parent is gone), and rewrites the handles
// the world's Parent, Children, Skin and Animator components hold of the old entities. Returns
// the remap, root first. `held` stays as it was (copy_components only reads it).
// Cost: O(components of the subtree + skins' joints and clips' targets in the world).
Remap put_back(World& world, HeldSubtree& held);

// Copies `root`'s subtree as new entities, the copy of root placed right after root among its
// siblings and named `name`. Handles the copies hold of entities in the subtree point at their
// copies; a copy of a glTF node has GltfNodeCopy instead of GltfNode (it is new to the file and
// takes that node's mesh when saved), GltfScene and EntityKey are not copied (keys are unique).
// Returns the remap, root first. Precondition: world.alive(root).
// Cost: O(components of the subtree).
Remap copy_subtree(World& world, Entity root, const std::string& name);

// "NAME (2)", "NAME (3)", ...: the first that no sibling of `e` (the roots, for a root) is named.
std::string copy_name(World& world, Entity e);

}  // namespace penumbra::editor
