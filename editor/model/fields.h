// The editable fields of every component the editor knows: one table that the inspector draws,
// the script's `set ENTITY COMPONENT.FIELD VALUE` parses, and undo records (before/after values).
// The scene's components are listed here; every lighting module's come from its field lists
// (LightingModule::components, lighting/fields.h), and so do the presets.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"

namespace penumbra::editor {

// A field's value and kind: the lighting layer's (lighting/fields.h). Rotations are quaternions
// (the inspector and scripts show Euler degrees).
using FieldValue = penumbra::FieldValue;
using FieldKind = penumbra::FieldType;

struct FieldDesc {
  std::string component;             // component_name(), e.g. "Light"
  std::string name;                  // e.g. "intensity"
  FieldKind kind = FieldKind::Float;
  std::vector<std::string> choices;  // Enum: the names of the values, e.g. {"L1", "L2"}
  double min = -1e30, max = 1e30;    // accepted range (scalars and each vector component)
  float speed = 0.01f;               // drag speed for the inspector
  std::string unit;                  // e.g. "m"; empty for none
  std::string help;                  // one line for a tooltip
  bool read_only = false;            // written by systems or bakers (shown, not edited)
  std::function<bool(World&, Entity)> present;
  std::function<FieldValue(World&, Entity)> get;
  // Writes the value with World::patch (so systems and the renderer see the change). Precondition:
  // present() and the value has the field's type and range (parse_field_value / check_field_value).
  std::function<void(World&, Entity, const FieldValue&)> set;
};

// Every field, grouped by component in a fixed order. Thread-safe (built once).
std::span<const FieldDesc> editable_fields();
// The field "COMPONENT.FIELD", or nullptr.
const FieldDesc* find_field(std::string_view component, std::string_view field);
// The components that have fields, in table order, and whether an entity has each.
std::vector<std::string> field_components();

// Parses a value written as in scripts: "true"/"false"/"1"/"0", integers, enum names, floats, and
// vectors as space- or comma-separated numbers ("1 2 3"); rotations as Euler angles in degrees
// (X, Y, Z applied in that order). Errors name the field, what was expected and the range.
Result<FieldValue> parse_field_value(const FieldDesc& field, std::string_view text);
// InvalidArgument when the value has the wrong type, is not finite or is out of range.
Status check_field_value(const FieldDesc& field, const FieldValue& value);
// The value as parse_field_value reads it (round-trips up to float printing, 9 digits).
std::string format_field_value(const FieldDesc& field, const FieldValue& value);

// A quality preset of a lighting component, applied by the inspector and by `preset ENTITY WHAT P`.
struct ComponentPreset {
  std::string technique;  // the script's word: the module's name (LightingModule::name)
  std::string component;  // its component's type name (ComponentInfo::name)
  std::function<bool(World&, Entity)> present;
  // Sets the preset's quality knobs with World::patch, keeping placement (box, priority, blending)
  // and baked data.
  std::function<void(World&, Entity, Preset)> apply;
};
std::span<const ComponentPreset> component_presets();
const ComponentPreset* find_preset(std::string_view technique);

// The lighting components a user can add to an entity (ComponentInfo::emplace), by type name, in
// the modules' order; and their names, comma-separated, for messages.
std::vector<const ComponentInfo*> authored_component_infos();
const ComponentInfo* find_authored_component(std::string_view name);
std::string authored_component_names();

}  // namespace penumbra::editor
