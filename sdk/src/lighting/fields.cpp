// Field lists: range checks, hashing and presets derived from them (see fields.h).
#include "penumbra/lighting/fields.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace penumbra {

namespace {

const char* type_name(FieldType type) {
  switch (type) {
    case FieldType::Bool: return "true or false";
    case FieldType::Int: return "an integer";
    case FieldType::Count: return "a non-negative integer";
    case FieldType::Enum: return "one of its choices";
    case FieldType::Float: return "a number";
    case FieldType::Vec2: return "two numbers";
    case FieldType::Vec3: return "three numbers";
    case FieldType::Color: return "a linear RGB colour";
    case FieldType::Count3: return "three non-negative integers";
    case FieldType::Rotation: return "a rotation";
    case FieldType::Text: return "a string";
  }
  return "a value";
}

bool holds_type(FieldType type, const FieldValue& v) {
  switch (type) {
    case FieldType::Bool: return std::holds_alternative<bool>(v);
    case FieldType::Int:
    case FieldType::Count:
    case FieldType::Enum: return std::holds_alternative<std::int64_t>(v);
    case FieldType::Float: return std::holds_alternative<float>(v);
    case FieldType::Vec2: return std::holds_alternative<glm::vec2>(v);
    case FieldType::Vec3:
    case FieldType::Color: return std::holds_alternative<glm::vec3>(v);
    case FieldType::Count3: return std::holds_alternative<glm::uvec3>(v);
    case FieldType::Rotation: return std::holds_alternative<glm::quat>(v);
    case FieldType::Text: return std::holds_alternative<std::string>(v);
  }
  return false;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

const FieldInfo* ComponentInfo::field(std::string_view field_name) const {
  for (const FieldInfo& f : fields)
    if (f.name == field_name) return &f;
  return nullptr;
}

Result<FieldValue> field_value_from(const FieldInfo& f, const AuthoredValue& a) {
  const std::string where = "field '" + std::string(f.name) + "'";
  const auto bad = [&](const std::string& form) {
    return make_error(ErrorCode::InvalidArgument, where + " takes " + form);
  };
  const auto* number = std::get_if<double>(&a);
  const auto* numbers = std::get_if<std::vector<double>>(&a);
  const auto integral = [](double x) { return std::isfinite(x) && x == std::floor(x) && std::abs(x) < 0x1p53; };
  // Numbers beyond the float range (converting them is undefined) or not finite are refused here.
  const auto in_float_range = [](double x) { return std::isfinite(x) && std::abs(x) <= 3.4028234663852886e38; };
  if ((number && !in_float_range(*number)) ||
      (numbers && !std::all_of(numbers->begin(), numbers->end(), in_float_range)))
    return make_error(ErrorCode::InvalidArgument, where + " takes finite numbers within +-3.4e38");
  FieldValue v;
  switch (f.type) {
    case FieldType::Bool:
      if (!std::holds_alternative<bool>(a)) return bad("true or false");
      v = std::get<bool>(a);
      break;
    case FieldType::Int:
    case FieldType::Count:
      if (!number || !integral(*number)) return bad("an integer");
      v = static_cast<std::int64_t>(*number);
      break;
    case FieldType::Enum: {
      std::string names;
      for (std::size_t c = 0; c < f.choices.size(); ++c) {
        names += (c > 0 ? ", \"" : "\"") + std::string(f.choices[c]) + "\"";
        if (const auto* s = std::get_if<std::string>(&a); s && *s == f.choices[c]) v = static_cast<std::int64_t>(c);
      }
      if (!std::holds_alternative<std::int64_t>(v)) return bad("one of " + names);
      break;
    }
    case FieldType::Float:
      if (!number) return bad("a number");
      v = static_cast<float>(*number);
      break;
    case FieldType::Vec2:
      if (!numbers || numbers->size() != 2) return bad("an array of 2 numbers");
      v = glm::vec2((*numbers)[0], (*numbers)[1]);
      break;
    case FieldType::Vec3:
    case FieldType::Color:
      if (!numbers || numbers->size() != 3) return bad("an array of 3 numbers");
      v = glm::vec3((*numbers)[0], (*numbers)[1], (*numbers)[2]);
      break;
    case FieldType::Count3:
      if (!numbers || numbers->size() != 3 || !std::all_of(numbers->begin(), numbers->end(), integral) ||
          *std::min_element(numbers->begin(), numbers->end()) < 0)
        return bad("an array of 3 non-negative integers");
      v = glm::uvec3(static_cast<std::uint32_t>(std::min((*numbers)[0], 4294967295.0)),
                     static_cast<std::uint32_t>(std::min((*numbers)[1], 4294967295.0)),
                     static_cast<std::uint32_t>(std::min((*numbers)[2], 4294967295.0)));
      break;
    case FieldType::Rotation:
      if (!numbers || numbers->size() != 4) return bad("a quaternion [x, y, z, w]");
      v = glm::quat(static_cast<float>((*numbers)[3]), static_cast<float>((*numbers)[0]),
                    static_cast<float>((*numbers)[1]), static_cast<float>((*numbers)[2]));
      break;
    case FieldType::Text:
      if (!std::holds_alternative<std::string>(a)) return bad("a string");
      v = std::get<std::string>(a);
      break;
  }
  PENUMBRA_TRY(check_field_value(f, v));
  return v;
}

AuthoredValue authored_value(const FieldInfo& f, const FieldValue& v) {
  return std::visit(
      [&](const auto& x) -> AuthoredValue {
        using X = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<X, bool>) {
          return x;
        } else if constexpr (std::is_same_v<X, std::int64_t>) {
          if (f.type == FieldType::Enum && x >= 0 && static_cast<std::size_t>(x) < f.choices.size())
            return std::string(f.choices[static_cast<std::size_t>(x)]);
          return static_cast<double>(x);
        } else if constexpr (std::is_same_v<X, float>) {
          return static_cast<double>(x);
        } else if constexpr (std::is_same_v<X, glm::quat>) {
          return std::vector<double>{x.x, x.y, x.z, x.w};
        } else if constexpr (std::is_same_v<X, std::string>) {
          return x;
        } else {
          std::vector<double> out;
          for (int i = 0; i < static_cast<int>(X::length()); ++i) out.push_back(static_cast<double>(x[i]));
          return out;
        }
      },
      v);
}

Status check_field_value(const FieldInfo& f, const FieldValue& v) {
  const std::string where = "field '" + std::string(f.name) + "'";
  if (!holds_type(f.type, v))
    return make_error(ErrorCode::InvalidArgument, where + " takes " + type_name(f.type));
  // Every scalar component, as a double (a rotation is only checked for finiteness).
  if (const auto* text = std::get_if<std::string>(&v)) {
    if (static_cast<double>(text->size()) > f.max)
      return make_error(ErrorCode::InvalidArgument, where + " is " + std::to_string(text->size()) +
                                                        " characters long; at most " + number(f.max) + " fit");
    return {};
  }
  double values[4];
  int n = 0;
  bool ranged = true;
  std::visit(
      [&](const auto& x) {
        using X = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<X, bool> || std::is_same_v<X, std::string>) {
          ranged = false;
        } else if constexpr (std::is_same_v<X, std::int64_t> || std::is_same_v<X, float>) {
          values[n++] = static_cast<double>(x);
        } else {
          ranged = !std::is_same_v<X, glm::quat>;
          for (int i = 0; i < static_cast<int>(X::length()); ++i) values[n++] = static_cast<double>(x[i]);
        }
      },
      v);
  std::string unit;  // " m", or empty
  if (!f.unit.empty()) unit.append(" ").append(f.unit);
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(values[i]))
      return make_error(ErrorCode::InvalidArgument, where + " is NaN or infinite; give a finite value");
    // Float fields are compared with the bounds as floats, so that a bound like 0.999 is accepted.
    const bool single = f.type == FieldType::Float || f.type == FieldType::Vec2 || f.type == FieldType::Vec3 ||
                        f.type == FieldType::Color;
    const double lo = single ? static_cast<double>(static_cast<float>(f.min)) : f.min;
    const double hi = single ? static_cast<double>(static_cast<float>(f.max)) : f.max;
    if (ranged && (values[i] < lo || values[i] > hi)) {
      std::string message = where + " = " + number(values[i]) + unit + " is outside " + number(f.min) + ".." +
                            number(f.max) + unit;
      if (f.type == FieldType::Enum) {
        message = where + " = " + number(values[i]) + " is not one of ";
        for (std::size_t c = 0; c < f.choices.size(); ++c) {
          if (c > 0) message += ", ";
          message += f.choices[c];
        }
      }
      if (!f.help.empty()) message += " (" + std::string(f.help) + ")";
      return make_error(ErrorCode::InvalidArgument, message);
    }
  }
  return {};
}

Status check_fields(const ComponentInfo& info, const void* component, std::string_view context) {
  for (const FieldInfo& f : info.fields) {
    if (f.read_only) continue;
    if (Status s = check_field_value(f, f.get(component)); !s)
      return Error{s.error().code, std::string(context) + ": " + s.error().message};
  }
  return {};
}

void hash_fields(const ComponentInfo& info, const void* component, Hasher& h) {
  for (const FieldInfo& f : info.fields) {
    if (!f.hashed) continue;
    const FieldValue v = f.get(component);
    h.add(v.index());
    std::visit(
        [&](const auto& x) {
          if constexpr (std::is_same_v<std::decay_t<decltype(x)>, std::string>) h.add(std::string_view(x));
          else h.add(x);
        },
        v);
  }
}

void apply_preset(const ComponentInfo& info, World& world, Entity e, Preset preset) {
  info.set_preset_fields(info, info.patch(world, e), preset);
}

}  // namespace penumbra
