// Undo stack of field edits (undo.h).
#include "undo.h"

namespace penumbra::editor {

namespace {

bool applicable(World& world, const Edit& edit) {
  if (!world.alive(edit.entity)) return false;
  for (const FieldChange& c : edit.changes)
    if (!c.field->present(world, edit.entity) || !c.field->set) return false;
  return true;
}

}  // namespace

Status UndoStack::set(World& world, Entity entity, const FieldDesc& field, const FieldValue& value, bool merge) {
  const std::string name = field.component + "." + field.name;
  if (!world.alive(entity))
    return make_error(ErrorCode::InvalidArgument, "set " + name + ": the entity no longer exists; select another");
  if (!field.present(world, entity))
    return make_error(ErrorCode::InvalidArgument,
                      "set " + name + ": the entity has no " + field.component + " component; select one that has");
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

void UndoStack::push(Edit edit) {
  entries_.resize(position_);  // a new edit drops the undone ones
  entries_.push_back(std::move(edit));
  position_ = entries_.size();
}

bool UndoStack::undo(World& world) {
  merging_ = false;
  if (position_ == 0) return false;
  const Edit& e = entries_[position_ - 1];
  if (!applicable(world, e)) {
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(position_ - 1));
    --position_;
    return false;
  }
  // Undo in reverse order so that a field changed twice ends at its first value.
  for (auto c = e.changes.rbegin(); c != e.changes.rend(); ++c) c->field->set(world, e.entity, c->before);
  --position_;
  return true;
}

bool UndoStack::redo(World& world) {
  merging_ = false;
  if (position_ == entries_.size()) return false;
  const Edit& e = entries_[position_];
  if (!applicable(world, e)) {
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(position_));
    return false;
  }
  for (const FieldChange& c : e.changes) c.field->set(world, e.entity, c.after);
  ++position_;
  return true;
}

void UndoStack::clear() {
  entries_.clear();
  position_ = 0;
  merging_ = false;
}

}  // namespace penumbra::editor
