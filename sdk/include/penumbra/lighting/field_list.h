// Helpers for a module's field lists (fields.h): accessors made from member pointers, so that a
// list reads as one line per member.
//
//   constexpr FieldInfo kFields[] = {
//       member<&IrradianceProbeGrid::spacing>({.name = "spacing", .type = FieldType::Float, ...}),
//   };
#pragma once

#include <type_traits>

#include "penumbra/ecs/world.h"
#include "penumbra/lighting/fields.h"

namespace penumbra::fields {

template <class T>
struct member_of;
template <class C, class M>
struct member_of<M C::*> {
  using component = C;
  using type = M;
};

// A member's value as the FieldValue alternative of its type (enums and integers as int64).
template <class M>
FieldValue to_value(const M& m) {
  if constexpr (std::is_same_v<M, bool> || std::is_same_v<M, float> || std::is_same_v<M, glm::vec2> ||
                std::is_same_v<M, glm::vec3> || std::is_same_v<M, glm::uvec3> || std::is_same_v<M, glm::quat> ||
                std::is_same_v<M, std::string>)
    return m;
  else
    return static_cast<std::int64_t>(m);
}
template <class M>
M from_value(const FieldValue& v) {
  if constexpr (std::is_same_v<M, bool> || std::is_same_v<M, float> || std::is_same_v<M, glm::vec2> ||
                std::is_same_v<M, glm::vec3> || std::is_same_v<M, glm::uvec3> || std::is_same_v<M, glm::quat> ||
                std::is_same_v<M, std::string>)
    return std::get<M>(v);
  else
    return static_cast<M>(std::get<std::int64_t>(v));
}

// `info` with get and set reading and writing member P.
template <auto P>
constexpr FieldInfo member(FieldInfo info) {
  using C = typename member_of<decltype(P)>::component;
  using M = typename member_of<decltype(P)>::type;
  info.get = [](const void* c) { return to_value(static_cast<const C*>(c)->*P); };
  if (!info.read_only) info.set = [](void* c, const FieldValue& v) { static_cast<C*>(c)->*P = from_value<M>(v); };
  return info;
}

// A ComponentInfo's World access for component C.
template <class C>
const void* find_in(const World& world, Entity e) {
  return world.try_get<C>(e);
}
template <class C>
void* patch_in(World& world, Entity e) {
  return &world.patch<C>(e);
}
template <class C>
void emplace_in(World& world, Entity e) {
  world.add<C>(e);
}
template <class C>
void erase_in(World& world, Entity e) {
  world.remove<C>(e);
}
template <class C>
void copy_in(const World& from, Entity src, World& to, Entity dst) {
  if (const C* c = from.try_get<C>(src)) to.add<C>(dst, *c);
}
// set_preset_fields for a component with a static C::preset(Preset).
template <class C>
void preset_fields(const ComponentInfo& info, void* component, Preset preset) {
  const C from = C::preset(preset);
  for (const FieldInfo& f : info.fields)
    if (f.preset && f.set) f.set(component, f.get(&from));
}

}  // namespace penumbra::fields
