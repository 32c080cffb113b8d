// The field table (fields.h): one entry per editable member, built from member pointers.
#include "fields.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <type_traits>

#include <glm/gtc/quaternion.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/lighting/field_list.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

namespace {

using fields::from_value;
using fields::to_value;

template <class C>
std::function<bool(World&, Entity)> has() {
  return [](World& w, Entity e) { return w.has<C>(e); };
}

// A field for member `ptr` of component C.
template <class C, class M>
FieldDesc member(const char* name, FieldKind kind, M C::*ptr, double min = -1e30, double max = 1e30,
                 float speed = 0.01f) {
  FieldDesc f;
  f.component = std::string(component_name(component_id<C>()));
  f.name = name;
  f.kind = kind;
  f.min = min;
  f.max = max;
  f.speed = speed;
  f.present = has<C>();
  f.get = [ptr](World& w, Entity e) { return to_value(w.get<C>(e).*ptr); };
  f.set = [ptr](World& w, Entity e, const FieldValue& v) { w.patch<C>(e).*ptr = from_value<M>(v); };
  return f;
}

FieldDesc described(FieldDesc f, const char* unit, const char* help) {
  f.unit = unit;
  f.help = help;
  return f;
}

FieldDesc with_choices(FieldDesc f, std::vector<std::string> choices) {
  f.choices = std::move(choices);
  f.min = 0;
  f.max = static_cast<double>(f.choices.size() - 1);
  return f;
}

std::vector<FieldDesc> build_fields() {
  std::vector<FieldDesc> t;
  constexpr double kBig = 1e30;
  // Transform (ecs): the local TRS.
  t.push_back(described(member("translation", FieldKind::Vec3, &Transform::translation, -1e6, 1e6, 0.02f), "m",
                        "position relative to the parent"));
  t.push_back(described(member("rotation", FieldKind::Rotation, &Transform::rotation), "deg",
                        "Euler angles relative to the parent (X, Y, Z)"));
  t.push_back(described(member("scale", FieldKind::Vec3, &Transform::scale, 1e-6, 1e6, 0.01f), "",
                        "scale along the local axes, applied before the rotation"));

  // Light (scene).
  t.push_back(with_choices(member("type", FieldKind::Enum, &Light::type), {"directional", "point", "spot", "rect"}));
  t.push_back(described(member("color", FieldKind::Color, &Light::color, 0.0, kBig), "",
                        "linear RGB; multiplies the intensity"));
  t.push_back(described(member("intensity", FieldKind::Float, &Light::intensity, 0.0, kBig, 0.05f), "",
                        "directional: illuminance in lux; point and spot: intensity in candela; rect: radiance in "
                        "W/(m^2 sr)"));
  t.push_back(described(member("range", FieldKind::Float, &Light::range, 0.0, kBig, 0.05f), "m",
                        "distance at which the light fades to nothing; 0: no limit"));
  t.push_back(described(member("inner_cone_angle", FieldKind::Float, &Light::inner_cone_angle, 0.0, 3.1415926, 0.005f),
                        "rad", "spot: full intensity inside this angle from the axis"));
  t.push_back(described(member("outer_cone_angle", FieldKind::Float, &Light::outer_cone_angle, 0.0, 3.1415926, 0.005f),
                        "rad", "spot: no light beyond this angle from the axis"));
  t.push_back(described(member("size", FieldKind::Vec2, &Light::size, 0.0, kBig, 0.01f), "m",
                        "rect: width (local X) and height (local Y)"));

  // Environment (scene): the sky.
  t.push_back(described(member("radiance", FieldKind::Color, &Environment::radiance, 0.0, kBig), "W/(m^2 sr)",
                        "sky radiance, uniform over directions (without a map); lights the scene through the bakes"));
  {
    FieldDesc f = described(member("map", FieldKind::Text, &Environment::map, 0.0, 4096.0), "",
                            "the sky's equirectangular OpenEXR map, as the glTF names it (set in the file)");
    f.read_only = true;  // the texels come with the file; editing the name would not reload them
    t.push_back(std::move(f));
  }
  t.push_back(described(member("map_scale", FieldKind::Float, &Environment::map_scale, 0.0, kBig, 0.01f), "",
                        "the map's texels are multiplied by this (with a map)"));

  // Material (scene): base colour split into RGB and alpha.
  {
    FieldDesc f;
    f.component = "Material";
    f.name = "base_color";
    f.kind = FieldKind::Color;
    f.min = 0.0;
    f.max = 1.0;
    f.present = has<Material>();
    f.get = [](World& w, Entity e) { return FieldValue(glm::vec3(w.get<Material>(e).base_color)); };
    f.set = [](World& w, Entity e, const FieldValue& v) {
      Material& m = w.patch<Material>(e);
      m.base_color = glm::vec4(std::get<glm::vec3>(v), m.base_color.a);
    };
    t.push_back(std::move(f));
    FieldDesc a;
    a.component = "Material";
    a.name = "alpha";
    a.kind = FieldKind::Float;
    a.min = 0.0;
    a.max = 1.0;
    a.present = has<Material>();
    a.get = [](World& w, Entity e) { return FieldValue(w.get<Material>(e).base_color.a); };
    a.set = [](World& w, Entity e, const FieldValue& v) { w.patch<Material>(e).base_color.a = std::get<float>(v); };
    t.push_back(std::move(a));
  }
  t.push_back(member("emissive", FieldKind::Color, &Material::emissive, 0.0, kBig));
  t.push_back(member("double_sided", FieldKind::Bool, &Material::double_sided));

  // Camera (scene).
  t.push_back(described(member("yfov", FieldKind::Float, &Camera::yfov, 0.01, 3.1, 0.005f), "rad", "vertical field of view"));
  t.push_back(described(member("aspect", FieldKind::Float, &Camera::aspect, 0.0, 100.0), "",
                        "as authored (width / height); views use the window's"));
  t.push_back(described(member("znear", FieldKind::Float, &Camera::znear, 1e-6, kBig, 0.001f), "m", "near clip distance"));
  t.push_back(described(member("zfar", FieldKind::Float, &Camera::zfar, 1e-5, kBig, 1.0f), "m", "far clip distance"));

  // Animator (scene).
  t.push_back(member("clip", FieldKind::Count, &Animator::clip, 0.0, 1e9));
  t.push_back(described(member("time", FieldKind::Float, &Animator::time, 0.0, kBig), "s", "playback time in the clip"));
  t.push_back(described(member("speed", FieldKind::Float, &Animator::speed, -100.0, 100.0), "x",
                        "playback rate; negative plays backwards"));
  t.push_back(member("loop", FieldKind::Bool, &Animator::loop));
  t.push_back(member("playing", FieldKind::Bool, &Animator::playing));

  // Every lighting module's components, from their field lists.
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components)
      for (const FieldInfo& info : c->fields) {
        FieldDesc f;
        f.component = std::string(c->name);
        f.name = std::string(info.name);
        f.kind = info.type;
        for (std::string_view choice : info.choices) f.choices.emplace_back(choice);
        f.min = info.min;
        f.max = info.max;
        f.speed = info.speed;
        f.unit = std::string(info.unit);
        f.help = std::string(info.help);
        f.read_only = info.read_only;
        f.present = [c](World& w, Entity e) { return c->present(w, e); };
        f.get = [c, get = info.get](World& w, Entity e) { return get(c->find(w, e)); };
        if (info.set)
          f.set = [c, set = info.set](World& w, Entity e, const FieldValue& v) { set(c->patch(w, e), v); };
        t.push_back(std::move(f));
      }
  return t;
}

// Splits "1, 2 3" into numbers; false on anything else.
bool parse_numbers(std::string_view text, std::vector<double>& out) {
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == ',' || text[i] == '\t')) ++i;
    if (i == text.size()) break;
    double v = 0.0;
    const auto [end, ec] = std::from_chars(text.data() + i, text.data() + text.size(), v);
    if (ec != std::errc()) return false;
    out.push_back(v);
    i = static_cast<std::size_t>(end - text.data());
    if (i < text.size() && text[i] != ' ' && text[i] != ',' && text[i] != '\t') return false;
  }
  return true;
}

std::string kind_help(const FieldDesc& f) {
  switch (f.kind) {
    case FieldKind::Bool: return "true or false";
    case FieldKind::Int: return "an integer";
    case FieldKind::Count: return "a whole number";
    case FieldKind::Enum: {
      std::string s = "one of";
      for (const auto& c : f.choices) s += " " + c;
      return s;
    }
    case FieldKind::Float: return "a number";
    case FieldKind::Vec2: return "two numbers (x y)";
    case FieldKind::Vec3: return "three numbers (x y z)";
    case FieldKind::Color: return "three numbers (r g b)";
    case FieldKind::Count3: return "three whole numbers (x y z)";
    case FieldKind::Rotation: return "three Euler angles in degrees (x y z)";
    case FieldKind::Text: return "text";
  }
  return "a value";
}

std::string range_text(const FieldDesc& f) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%g, %g]", f.min, f.max);
  return buf;
}

}  // namespace

std::span<const FieldDesc> editable_fields() {
  static const std::vector<FieldDesc> fields = build_fields();
  return fields;
}

const FieldDesc* find_field(std::string_view component, std::string_view field) {
  for (const FieldDesc& f : editable_fields())
    if (f.component == component && f.name == field) return &f;
  return nullptr;
}

std::vector<std::string> field_components() {
  std::vector<std::string> out;
  for (const FieldDesc& f : editable_fields())
    if (out.empty() || out.back() != f.component) out.push_back(f.component);
  return out;
}

Result<FieldValue> parse_field_value(const FieldDesc& f, std::string_view text) {
  const std::string where = f.component + "." + f.name + ": '" + std::string(text) + "' is not ";
  const auto bad = [&] { return make_error(ErrorCode::InvalidArgument, where + kind_help(f)); };
  FieldValue value;
  if (f.kind == FieldKind::Bool) {
    if (text == "true" || text == "1") value = true;
    else if (text == "false" || text == "0") value = false;
    else return bad();
  } else if (f.kind == FieldKind::Text) {
    value = std::string(text);
  } else if (f.kind == FieldKind::Enum) {
    bool found = false;
    for (std::size_t i = 0; i < f.choices.size(); ++i)
      if (f.choices[i] == text) {
        value = static_cast<std::int64_t>(i);
        found = true;
      }
    if (!found) return bad();
  } else {
    std::vector<double> n;
    if (!parse_numbers(text, n)) return bad();
    switch (f.kind) {
      case FieldKind::Int:
      case FieldKind::Count:
        if (n.size() != 1 || n[0] != std::floor(n[0]) || std::abs(n[0]) > 9e15) return bad();
        value = static_cast<std::int64_t>(n[0]);
        break;
      case FieldKind::Float:
        if (n.size() != 1) return bad();
        value = static_cast<float>(n[0]);
        break;
      case FieldKind::Vec2:
        if (n.size() != 2) return bad();
        value = glm::vec2(static_cast<float>(n[0]), static_cast<float>(n[1]));
        break;
      case FieldKind::Vec3:
      case FieldKind::Color:
        if (n.size() != 3) return bad();
        value = glm::vec3(static_cast<float>(n[0]), static_cast<float>(n[1]), static_cast<float>(n[2]));
        break;
      case FieldKind::Count3:
        if (n.size() != 3) return bad();
        for (double x : n)
          if (!(x >= 0.0 && x < 4294967296.0 && x == std::floor(x))) return bad();
        value = glm::uvec3(static_cast<std::uint32_t>(n[0]), static_cast<std::uint32_t>(n[1]),
                           static_cast<std::uint32_t>(n[2]));
        break;
      case FieldKind::Rotation:
        if (n.size() != 3 || !std::isfinite(n[0]) || !std::isfinite(n[1]) || !std::isfinite(n[2])) return bad();
        value = glm::quat(glm::radians(glm::vec3(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                                 static_cast<float>(n[2]))));
        break;
      default: return bad();
    }
  }
  PENUMBRA_TRY(check_field_value(f, value));
  return value;
}

Status check_field_value(const FieldDesc& f, const FieldValue& value) {
  const std::string where = f.component + "." + f.name + ": ";
  // Float kinds compare with the bounds as floats (a bound like 0.999 is accepted).
  const bool single = f.kind == FieldKind::Float || f.kind == FieldKind::Vec2 || f.kind == FieldKind::Vec3 ||
                      f.kind == FieldKind::Color;
  const double lo = single ? static_cast<double>(static_cast<float>(f.min)) : f.min;
  const double hi = single ? static_cast<double>(static_cast<float>(f.max)) : f.max;
  const auto in_range = [&](double v) { return std::isfinite(v) && v >= lo && v <= hi; };
  const auto out_of_range = [&] {
    return make_error(ErrorCode::InvalidArgument,
                      where + "the value is outside " + range_text(f) + "; give a finite value in that range");
  };
  const auto wrong_type = [&] {
    return make_error(ErrorCode::InvalidArgument, where + "the value is not " + kind_help(f));
  };
  switch (f.kind) {
    case FieldKind::Bool: return std::holds_alternative<bool>(value) ? Status{} : wrong_type();
    case FieldKind::Int:
    case FieldKind::Count:
    case FieldKind::Enum:
      if (!std::holds_alternative<std::int64_t>(value)) return wrong_type();
      return in_range(static_cast<double>(std::get<std::int64_t>(value))) ? Status{} : out_of_range();
    case FieldKind::Float:
      if (!std::holds_alternative<float>(value)) return wrong_type();
      return in_range(std::get<float>(value)) ? Status{} : out_of_range();
    case FieldKind::Vec2: {
      if (!std::holds_alternative<glm::vec2>(value)) return wrong_type();
      const glm::vec2 v = std::get<glm::vec2>(value);
      return in_range(v.x) && in_range(v.y) ? Status{} : out_of_range();
    }
    case FieldKind::Vec3:
    case FieldKind::Color: {
      if (!std::holds_alternative<glm::vec3>(value)) return wrong_type();
      const glm::vec3 v = std::get<glm::vec3>(value);
      return in_range(v.x) && in_range(v.y) && in_range(v.z) ? Status{} : out_of_range();
    }
    case FieldKind::Count3: {
      if (!std::holds_alternative<glm::uvec3>(value)) return wrong_type();
      const glm::uvec3 v = std::get<glm::uvec3>(value);
      return in_range(v.x) && in_range(v.y) && in_range(v.z) ? Status{} : out_of_range();
    }
    case FieldKind::Rotation: {
      if (!std::holds_alternative<glm::quat>(value)) return wrong_type();
      const glm::quat q = std::get<glm::quat>(value);
      const float len = glm::length(q);
      return std::isfinite(len) && std::abs(len - 1.0f) < 1e-3f
                 ? Status{}
                 : make_error(ErrorCode::InvalidArgument, where + "the rotation is not a unit quaternion");
    }
    case FieldKind::Text:
      if (!std::holds_alternative<std::string>(value)) return wrong_type();
      return static_cast<double>(std::get<std::string>(value).size()) <= f.max
                 ? Status{}
                 : make_error(ErrorCode::InvalidArgument, where + "the text is longer than " + range_text(f));
  }
  return wrong_type();
}

std::string format_field_value(const FieldDesc& f, const FieldValue& value) {
  char buf[160];
  switch (f.kind) {
    case FieldKind::Bool: return std::get<bool>(value) ? "true" : "false";
    case FieldKind::Enum: {
      const auto i = static_cast<std::size_t>(std::get<std::int64_t>(value));
      return i < f.choices.size() ? f.choices[i] : std::to_string(i);
    }
    case FieldKind::Int:
    case FieldKind::Count: return std::to_string(std::get<std::int64_t>(value));
    case FieldKind::Float: std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(std::get<float>(value))); break;
    case FieldKind::Vec2: {
      const glm::vec2 v = std::get<glm::vec2>(value);
      std::snprintf(buf, sizeof buf, "%.9g %.9g", static_cast<double>(v.x), static_cast<double>(v.y));
      break;
    }
    case FieldKind::Vec3:
    case FieldKind::Color: {
      const glm::vec3 v = std::get<glm::vec3>(value);
      std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g", static_cast<double>(v.x), static_cast<double>(v.y),
                    static_cast<double>(v.z));
      break;
    }
    case FieldKind::Count3: {
      const glm::uvec3 v = std::get<glm::uvec3>(value);
      std::snprintf(buf, sizeof buf, "%u %u %u", v.x, v.y, v.z);
      break;
    }
    case FieldKind::Rotation: {
      const glm::vec3 d = glm::degrees(glm::eulerAngles(std::get<glm::quat>(value)));
      std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g", static_cast<double>(d.x), static_cast<double>(d.y),
                    static_cast<double>(d.z));
      break;
    }
    case FieldKind::Text: return std::get<std::string>(value);
  }
  return buf;
}

std::span<const ComponentPreset> component_presets() {
  // Per module, its components that have presets.
  static const std::vector<ComponentPreset> presets = [] {
    std::vector<ComponentPreset> p;
    for (const LightingModule* m : lighting_modules())
      for (const ComponentInfo* c : m->components) {
        if (c->set_preset_fields == nullptr) continue;
        p.push_back({std::string(m->name), std::string(c->name), [c](World& w, Entity e) { return c->present(w, e); },
                     [c](World& w, Entity e, Preset q) { apply_preset(*c, w, e, q); }});
      }
    return p;
  }();
  return presets;
}

const ComponentPreset* find_preset(std::string_view technique) {
  for (const ComponentPreset& p : component_presets())
    if (p.technique == technique) return &p;
  return nullptr;
}

std::vector<const ComponentInfo*> authored_component_infos() {
  std::vector<const ComponentInfo*> out;
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components)
      if (c->emplace && c->erase) out.push_back(c);
  return out;
}

const ComponentInfo* find_authored_component(std::string_view name) {
  for (const ComponentInfo* c : authored_component_infos())
    if (c->name == name) return c;
  return nullptr;
}

std::string authored_component_names() {
  std::string names;
  for (const ComponentInfo* c : authored_component_infos()) names += (names.empty() ? "" : ", ") + std::string(c->name);
  return names;
}

}  // namespace penumbra::editor
