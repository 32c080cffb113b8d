// One field list per lighting component: each setting's name, type, range, unit, one line of help,
// whether a quality preset sets it and whether it enters the bake's input hash. Everything that
// needs to know a component's settings is derived from its list: the range checks of the module's
// validation (check_fields), the baker's input hash (hash_fields), the preset policy
// (apply_preset: preset fields from the preset, the rest kept), and the editor's inspector rows
// and script syntax. A module defines its lists in <module>_fields.cpp with
// the helpers of field_list.h and lists them in its descriptor (LightingModule::components).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include <glm/ext/quaternion_float.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/hash.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// A field's value. Rotations are quaternions (editors show Euler degrees).
using FieldValue = std::variant<bool, std::int64_t, float, glm::vec2, glm::vec3, glm::uvec3, glm::quat, std::string>;

enum class FieldType : std::uint8_t {
  Bool,      // bool
  Int,       // std::int64_t, any integer
  Count,     // std::int64_t, a non-negative integer (unsigned members)
  Enum,      // std::int64_t, index into `choices`
  Float,     // float
  Vec2,      // glm::vec2
  Vec3,      // glm::vec3
  Color,     // glm::vec3, linear RGB
  Count3,    // glm::uvec3, three counts (e.g. nodes per axis)
  Rotation,  // glm::quat
  Text,      // std::string of at most `max` bytes; what it may say, the component's validation checks
};

struct FieldInfo {
  std::string_view name;  // e.g. "samples_per_node": the inspector row and the script's key
  FieldType type = FieldType::Float;
  double min = -1e30, max = 1e30;             // accepted range (scalars and each vector component)
  std::span<const std::string_view> choices;  // Enum: the values' names, index = stored value
  std::string_view unit;                      // "m", "rad", "rays"...; empty for none
  std::string_view help;                      // one line: what it does and a good value
  bool preset = false;     // a quality preset sets it (apply_preset takes it from the preset)
  bool hashed = false;     // the bake reads it: it enters the input hash
  bool read_only = false;  // written by systems or bakers (shown, never set by hand)
  float speed = 0.01f;     // an inspector's drag speed
  FieldValue (*get)(const void* component) = nullptr;
  // Precondition: the value has the field's type and passes check_field_value.
  void (*set)(void* component, const FieldValue& value) = nullptr;
};

struct ComponentInfo {
  std::string_view name;  // the component's type name, e.g. "IrradianceProbeGrid"
  std::span<const FieldInfo> fields;
  const void* defaults = nullptr;  // a default-constructed component: each field's default value
  // Access in a World: the component of `e` or nullptr; patch() stamps the change tick.
  const void* (*find)(const World& world, Entity e) = nullptr;
  void* (*patch)(World& world, Entity e) = nullptr;
  // Copies the component of `src` in `from` (with its baked data) onto `dst` in `to`, when it has one.
  void (*copy)(const World& from, Entity src, World& to, Entity dst) = nullptr;
  // Sets every preset field of `component` to the preset's value (field_list.h: preset_fields<C>).
  // Null: the component has no presets.
  void (*set_preset_fields)(const ComponentInfo& info, void* component, Preset preset) = nullptr;
  // Adds a default-constructed component to `e`, replacing one present (World::add). Null for
  // components only the runtime adds (nobody authors them).
  void (*emplace)(World& world, Entity e) = nullptr;
  // Removes the component from `e` (World::remove; nothing when absent). Null with emplace.
  void (*erase)(World& world, Entity e) = nullptr;
  // The component belongs on an entity with a Mesh: a glTF node's declaration of it goes on each
  // of the node's mesh entities (one per primitive) rather than on the node's own entity.
  bool on_mesh = false;
  // Fits a component a user just added (the editor's Add) to what it is on: the probe grid's box
  // to the posed bounds of the entity's meshes, or to the scene's when it has none. Null: nothing
  // to fit. Precondition: the entity has the component; world transforms and poses are current.
  void (*fit)(World& world, Entity e) = nullptr;

  const FieldInfo* field(std::string_view name) const;
  bool present(const World& world, Entity e) const { return find(world, e) != nullptr; }
};

// InvalidArgument when `value` has the wrong type for the field, is not finite, or is out of
// range; the message names the field, the range and the unit.
Status check_field_value(const FieldInfo& field, const FieldValue& value);
// A field's value from its glTF (JSON) form (scene/components.h, AuthoredValue): true/false for
// Bool; an integer for Int and Count; a choice's name for Enum; a number for Float; an array of 2
// or 3 numbers for Vec2, Vec3 and Color, of 3 integers for Count3; [x, y, z, w] for Rotation; a
// string for Text.
// InvalidArgument naming the field and the form it takes; then check_field_value's checks.
Result<FieldValue> field_value_from(const FieldInfo& field, const AuthoredValue& value);
// The inverse: a field's value in that form (an Enum by its choice's name).
AuthoredValue authored_value(const FieldInfo& field, const FieldValue& value);
// Every field of `component` (a C of `info`) through check_field_value; the message starts with
// `context` (e.g. "probe grid 'hall' (entity 3)"). Cost: O(fields).
Status check_fields(const ComponentInfo& info, const void* component, std::string_view context);
// Adds every hashed field of `component`, in list order, to `hasher`: the input hash of its
// settings. A field the bake reads must be hashed, else an edit leaves the bake cache stale
// (lighting_modules_test changes each field in turn).
void hash_fields(const ComponentInfo& info, const void* component, Hasher& hasher);
// Sets the preset's value of every preset field of the component of `e` (World::patch), keeping
// every other field and the baked data. Precondition: info.present(world, e) and
// info.set_preset_fields.
void apply_preset(const ComponentInfo& info, World& world, Entity e, Preset preset);

}  // namespace penumbra
