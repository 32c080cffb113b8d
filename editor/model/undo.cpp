// Undo stack of field edits (undo.h).
#include "undo.h"

#include <utility>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

namespace {

// The settable fields of `info`'s component on `e`.
std::vector<std::pair<const FieldInfo*, FieldValue>> snapshot_of(World& world, Entity e, const ComponentInfo& info) {
  std::vector<std::pair<const FieldInfo*, FieldValue>> out;
  const void* c = info.find(world, e);
  for (const FieldInfo& f : info.fields)
    if (f.set && f.get && c) out.emplace_back(&f, f.get(c));
  return out;
}

// Puts the component back with its recorded fields / takes it away.
void restore(World& world, const Edit& e) {
  e.component->emplace(world, e.entity);
  void* c = e.component->patch(world, e.entity);
  for (const auto& [f, v] : e.snapshot) f->set(c, v);
}
void take_away(World& world, const Edit& e) { e.component->erase(world, e.entity); }

// Whether undoing (forward = false) or redoing the entry can be done: its entity is there, or for
// a subtree on its way back, its copies are held.
bool applicable(World& world, const Edit& edit, bool forward) {
  if (edit.subtree != Edit::Subtree::None)
    return (edit.subtree == Edit::Subtree::Created) == forward ? edit.held != nullptr : world.alive(edit.entity);
  if (!world.alive(edit.entity)) return false;
  if (edit.component) return true;
  for (const FieldChange& c : edit.changes)
    if (!c.field->present(world, edit.entity) || !c.field->set) return false;
  return true;
}

}  // namespace

Status UndoStack::set(World& world, Entity entity, const FieldDesc& field, const FieldValue& value, bool merge) {
  const std::string name = field.component + "." + field.name;
  if (!world.alive(entity))
    return make_error(ErrorCode::InvalidArgument, "set " + name + ": the entity no longer exists; select another");
  if (!field.present(world, entity)) {
    // A glTF node keeps per-mesh components on its primitives' entities: name them.
    std::string children;
    if (const Children* c = world.try_get<Children>(entity))
      for (Entity child : c->entities)
        if (world.alive(child) && field.present(world, child))
          if (const Name* n = world.try_get<Name>(child)) children += (children.empty() ? "'" : ", '") + n->value + "'";
    return make_error(ErrorCode::InvalidArgument,
                      "set " + name + ": the entity has no " + field.component + " component; select one that has" +
                          (children.empty() ? "" : " (its mesh primitives " + children + " have one)"));
  }
  if (field.read_only || !field.set)
    return make_error(ErrorCode::InvalidArgument, "set " + name + ": the field is written by the runtime, not editable");
  PENUMBRA_TRY(check_field_value(field, value));

  FieldChange change{&field, field.get(world, entity), value};
  field.set(world, entity, value);
  // A drag continues the previous entry when it edits the same field of the same entity.
  if (merge && merging_ && position_ == entries_.size() && position_ > 0) {
    Edit& last = entries_.back();
    if (last.entity == entity && last.changes.size() == 1 && last.changes[0].field == &field) {
      last.changes[0].after = value;
      return {};
    }
  }
  push(Edit{entity, "set " + name, {std::move(change)}});
  merging_ = merge;
  return {};
}

Status UndoStack::record(World& world, Entity entity, std::string_view component, std::string label,
                         const std::function<void()>& mutate) {
  if (!world.alive(entity))
    return make_error(ErrorCode::InvalidArgument, label + ": the entity no longer exists; select another");
  std::vector<const FieldDesc*> fields;
  std::vector<FieldValue> before;
  for (const FieldDesc& f : editable_fields())
    if (f.component == component && f.set && f.present(world, entity)) {
      fields.push_back(&f);
      before.push_back(f.get(world, entity));
    }
  mutate();
  Edit edit{entity, std::move(label), {}};
  for (std::size_t i = 0; i < fields.size(); ++i) {
    FieldValue after = fields[i]->get(world, entity);
    if (after != before[i]) edit.changes.push_back({fields[i], std::move(before[i]), std::move(after)});
  }
  if (!edit.changes.empty()) push(std::move(edit));
  merging_ = false;
  return {};
}

Status UndoStack::add_component(World& world, Entity entity, const ComponentInfo& info, std::optional<Preset> preset) {
  const std::string label = "add " + std::string(info.name);
  if (!world.alive(entity))
    return make_error(ErrorCode::InvalidArgument, label + ": the entity no longer exists; select another");
  if (!info.emplace || !info.erase)
    return make_error(ErrorCode::InvalidArgument, label + ": the runtime adds this component, not the user");
  if (info.present(world, entity))
    return make_error(ErrorCode::InvalidArgument, label + ": the entity already has one");
  if (info.on_mesh && !world.has<Mesh>(entity))
    return make_error(ErrorCode::InvalidArgument, label + ": it belongs on a mesh; select an entity with a Mesh");
  info.emplace(world, entity);
  if (preset && info.set_preset_fields) info.set_preset_fields(info, info.patch(world, entity), *preset);
  if (info.fit) info.fit(world, entity);
  Edit edit{entity, label, {}};
  edit.component = &info;
  edit.added = true;
  edit.snapshot = snapshot_of(world, entity, info);
  push(std::move(edit));
  merging_ = false;
  return {};
}

Status UndoStack::remove_component(World& world, Entity entity, const ComponentInfo& info) {
  const std::string label = "remove " + std::string(info.name);
  if (!world.alive(entity))
    return make_error(ErrorCode::InvalidArgument, label + ": the entity no longer exists; select another");
  if (!info.emplace || !info.erase)
    return make_error(ErrorCode::InvalidArgument, label + ": the runtime owns this component");
  if (!info.present(world, entity)) return make_error(ErrorCode::InvalidArgument, label + ": the entity has none");
  Edit edit{entity, label, {}};
  edit.component = &info;
  edit.added = false;
  edit.snapshot = snapshot_of(world, entity, info);
  info.erase(world, entity);
  push(std::move(edit));
  merging_ = false;
  return {};
}

void UndoStack::created(Entity root, std::string label) {
  Edit edit{root, std::move(label), {}};
  edit.subtree = Edit::Subtree::Created;
  push(std::move(edit));
  merging_ = false;
}

Status UndoStack::delete_subtree(World& world, Entity root) {
  if (!world.alive(root))
    return make_error(ErrorCode::InvalidArgument, "delete: the entity no longer exists; select another");
  const Name* name = world.try_get<Name>(root);
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "literal" + std::string&& here.
  std::string label = "delete '";
  if (name) {
    label += name->value;
  } else {
    label += '#';
    label += std::to_string(root.index);
  }
  label += '\'';
  Edit edit{root, std::move(label), {}};
  edit.subtree = Edit::Subtree::Deleted;
  take_out_subtree(world, edit);
  push(std::move(edit));
  merging_ = false;
  return {};
}

void UndoStack::take_out_subtree(World& world, Edit& edit) { edit.held = take_out(world, edit.entity); }

void UndoStack::put_back_subtree(World& world, Edit& edit) {
  const Remap remap = put_back(world, *edit.held);
  edit.held.reset();
  for (Edit& e : entries_)
    for (const auto& [from, to] : remap)
      if (e.entity == from) e.entity = to;
  restored_ = remap.front().second;
}

void UndoStack::push(Edit edit) {
  entries_.resize(position_);  // a new edit drops the undone ones
  entries_.push_back(std::move(edit));
  position_ = entries_.size();
}

bool UndoStack::undo(World& world) {
  merging_ = false;
  restored_ = Entity::null();
  if (position_ == 0) return false;
  Edit& e = entries_[position_ - 1];
  if (!applicable(world, e, false)) {
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(position_ - 1));
    --position_;
    return false;
  }
  if (e.subtree == Edit::Subtree::Created) take_out_subtree(world, e);
  if (e.subtree == Edit::Subtree::Deleted) put_back_subtree(world, e);
  if (e.component) {
    if (e.added) take_away(world, e);
    else restore(world, e);
  }
  // Undo in reverse order so that a field changed twice ends at its first value.
  for (auto c = e.changes.rbegin(); c != e.changes.rend(); ++c) c->field->set(world, e.entity, c->before);
  --position_;
  return true;
}

bool UndoStack::redo(World& world) {
  merging_ = false;
  restored_ = Entity::null();
  if (position_ == entries_.size()) return false;
  Edit& e = entries_[position_];
  if (!applicable(world, e, true)) {
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(position_));
    return false;
  }
  if (e.subtree == Edit::Subtree::Created) put_back_subtree(world, e);
  if (e.subtree == Edit::Subtree::Deleted) take_out_subtree(world, e);
  if (e.component) {
    if (e.added) restore(world, e);
    else take_away(world, e);
  }
  for (const FieldChange& c : e.changes) c.field->set(world, e.entity, c.after);
  ++position_;
  return true;
}

void UndoStack::clear() {
  entries_.clear();
  position_ = 0;
  merging_ = false;
  restored_ = Entity::null();
}

}  // namespace penumbra::editor
