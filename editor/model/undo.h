// Undo and redo of scene edits: each entry holds the before and after values of the fields it
// changed (fields.h), so undoing writes the old values back through the same setters; or a
// lighting component it added or removed with its field values; or an entity subtree it created
// or deleted, held as copies while it is out of the World (subtree.h). Putting a subtree back
// gives its entities new handles: every entry, and what restored() reports, follows them.
// Consecutive edits of one field of one entity made with `merge` (a drag in progress) become one
// entry that keeps the first before-value, until end_merge() (the drag ended) or another edit.
// Not thread-safe: use it with its World on the main thread.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fields.h"
#include "subtree.h"

namespace penumbra::editor {

struct FieldChange {
  const FieldDesc* field = nullptr;
  FieldValue before, after;
};

struct Edit {
  Entity entity;
  std::string label;  // for the Edit menu, e.g. "set Light.intensity"
  std::vector<FieldChange> changes;
  // A lighting component this entry added (added) or removed (!added), and the values of its
  // settable fields, restored whenever it comes back (its baked data does not: re-bake it).
  const ComponentInfo* component = nullptr;
  bool added = false;
  std::vector<std::pair<const FieldInfo*, FieldValue>> snapshot;
  // The subtree rooted at `entity` this entry created (a new or duplicated entity) or deleted;
  // `held` has its copies while it is out of the World.
  enum class Subtree : std::uint8_t { None, Created, Deleted };
  Subtree subtree = Subtree::None;
  std::shared_ptr<HeldSubtree> held;
};

class UndoStack {
 public:
  // Sets `field` of `entity` to `value` and records it. InvalidArgument (naming the field) for a
  // stale entity, a missing component, a read-only field or a bad value; nothing changes then.
  Status set(World& world, Entity entity, const FieldDesc& field, const FieldValue& value, bool merge = false);
  // Runs `mutate` (which changes fields of `component` on `entity`) and records the fields whose
  // values changed as one entry labelled `label`. For presets and other multi-field edits.
  Status record(World& world, Entity entity, std::string_view component, std::string label,
                const std::function<void()>& mutate);
  // Adds a lighting component to `entity` (its defaults, then `preset`'s values when it has
  // presets) / removes one, as an entry. InvalidArgument for a stale entity, a component that is
  // already there (add) or absent (remove), one that cannot be authored (no emplace), or a
  // per-mesh component (ComponentInfo::on_mesh) on an entity without a Mesh.
  Status add_component(World& world, Entity entity, const ComponentInfo& info, std::optional<Preset> preset);
  Status remove_component(World& world, Entity entity, const ComponentInfo& info);

  // Records that `root` and the entities below it were just made (a created or duplicated entity),
  // as an entry labelled `label`: undoing it takes them out, redoing puts them back.
  // Precondition: world.alive(root).
  void created(Entity root, std::string label);
  // Deletes `root` and every entity below it, as an entry. InvalidArgument for a stale handle.
  // Cost: a copy of the subtree's components (kept for undo).
  Status delete_subtree(World& world, Entity root);
  // The root of the subtree the last undo() or redo() put back (null when it put none back).
  Entity restored() const { return restored_; }

  // Writes the before-values of the latest entry back / the after-values of the next undone one.
  // False when there is nothing to undo/redo or the entity no longer has the component (the entry
  // is then dropped).
  bool undo(World& world);
  bool redo(World& world);
  // The next merged edit starts a new entry.
  void end_merge() { merging_ = false; }
  void clear();

  bool can_undo() const { return position_ > 0; }
  bool can_redo() const { return position_ < entries_.size(); }
  // Entries up to position() are applied; those after it were undone.
  std::size_t size() const { return entries_.size(); }
  std::size_t position() const { return position_; }
  const Edit& entry(std::size_t i) const { return entries_[i]; }

 private:
  void push(Edit edit);
  // Takes the entry's subtree out of / puts it back into the World (Subtree entries).
  void take_out_subtree(World& world, Edit& edit);
  void put_back_subtree(World& world, Edit& edit);

  std::vector<Edit> entries_;
  std::size_t position_ = 0;
  bool merging_ = false;
  Entity restored_;
};

}  // namespace penumbra::editor
