// Joint roles by name (joint_roles.h).
#include "penumbra/pose_ao/joint_roles.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <numbers>
#include <string>

#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

// The name lower-cased, without a namespace prefix ("mixamorig:", "Armature|") and with every
// character that is not a letter or digit turned into a space, padded with spaces so that whole
// words can be found as " word ".
std::string words(std::string_view name) {
  name = name_without_namespace(name);
  std::string out = " ";
  for (std::size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    // Split camel case ("LeftForeArm" -> "left fore arm") so that side words stand alone.
    if (std::isupper(c) && i > 0 && std::islower(static_cast<unsigned char>(name[i - 1]))) out += ' ';
    out += std::isalnum(c) ? static_cast<char>(std::tolower(c)) : ' ';
  }
  return out + " ";
}

bool has(const std::string& w, std::string_view part) { return w.find(part) != std::string::npos; }

}  // namespace

JointRole joint_role(std::string_view name) {
  const std::string w = words(name);
  // The same words with the spaces removed, for names that run words together ("forearm",
  // "upperarm", "upleg").
  std::string joined;
  for (char c : w)
    if (c != ' ') joined += c;
  if (has(w, " end ") || has(w, "nub") || has(w, " tip ")) return JointRole::End;
  // The palm's bones (Unreal's "index_metacarpal_l") move with the hand.
  if (has(joined, "metacarpal")) return JointRole::Hand;
  if (has(joined, "thumb") || has(joined, "index") || has(joined, "middle") || has(joined, "ring") ||
      has(joined, "pinky") || has(joined, "finger"))
    return JointRole::Finger;
  if (has(joined, "toe") || has(w, " ball ")) return JointRole::Toe;
  if (has(joined, "foot") || has(joined, "ankle")) return JointRole::Foot;
  if (has(joined, "thigh") || has(joined, "upleg") || has(joined, "upperleg")) return JointRole::Thigh;
  if (has(joined, "calf") || has(joined, "shin") || has(joined, "knee") || has(joined, "lowerleg") ||
      has(joined, "leg"))
    return JointRole::Calf;
  if (has(joined, "forearm") || has(joined, "lowerarm") || has(joined, "elbow")) return JointRole::Forearm;
  if (has(joined, "clavicle") || has(joined, "shoulder") || has(joined, "collar")) return JointRole::Clavicle;
  if (has(joined, "upperarm") || has(joined, "arm")) return JointRole::UpperArm;
  if (has(joined, "hand") || has(joined, "wrist") || has(joined, "palm")) return JointRole::Hand;
  if (has(joined, "neck")) return JointRole::Neck;
  if (has(joined, "head")) return JointRole::Head;
  if (has(joined, "spine") || has(joined, "chest") || has(joined, "torso") || has(joined, "abdomen"))
    return JointRole::Spine;
  if (has(joined, "hips") || has(joined, "pelvis") || has(w, " hip ")) return JointRole::Hips;
  return JointRole::Unknown;
}

const char* to_string(JointRole role) {
  switch (role) {
    case JointRole::Unknown: return "unknown";
    case JointRole::Hips: return "hips";
    case JointRole::Spine: return "spine";
    case JointRole::Neck: return "neck";
    case JointRole::Head: return "head";
    case JointRole::Clavicle: return "clavicle";
    case JointRole::UpperArm: return "upper arm";
    case JointRole::Forearm: return "forearm";
    case JointRole::Hand: return "hand";
    case JointRole::Finger: return "finger";
    case JointRole::FingerHinge: return "finger hinge";
    case JointRole::Thigh: return "thigh";
    case JointRole::Calf: return "calf";
    case JointRole::Foot: return "foot";
    case JointRole::Toe: return "toe";
    case JointRole::End: return "end";
  }
  return "unknown";
}

float role_limit(JointRole role, float unknown) {
  switch (role) {
    case JointRole::Unknown: return unknown;
    case JointRole::Hips: return 0.3f;
    case JointRole::Spine: return 0.25f;
    case JointRole::Neck: return 0.35f;
    case JointRole::Head: return 0.4f;
    case JointRole::Clavicle: return 0.25f;
    case JointRole::UpperArm: return 0.9f;
    case JointRole::Forearm: return 1.0f;
    case JointRole::Hand: return 0.6f;
    case JointRole::Finger:
    case JointRole::FingerHinge: return 0.5f;
    case JointRole::Thigh: return 0.7f;
    case JointRole::Calf: return 0.9f;
    case JointRole::Foot: return 0.4f;
    case JointRole::Toe: return 0.3f;
    case JointRole::End: return 0.0f;
  }
  return unknown;
}

void assign_chain_roles(std::span<const std::int32_t> parents, std::span<JointRole> roles) {
  const std::size_t J = parents.size();
  std::vector<std::vector<std::size_t>> children(J);
  for (std::size_t j = 0; j < J; ++j) {
    const auto p = static_cast<std::size_t>(parents[j]);
    if (parents[j] >= 0 && p < J) children[p].push_back(j);
  }
  const std::vector<JointRole> named(roles.begin(), roles.end());
  for (std::size_t start = 0; start < J; ++start) {
    const JointRole role = named[start];
    if (role != JointRole::UpperArm && role != JointRole::Calf) continue;
    // Only from a chain's start.
    if (parents[start] >= 0 && named[static_cast<std::size_t>(parents[start])] == role) continue;
    const bool arm = role == JointRole::UpperArm;
    using R = JointRole;
    const std::array<R, 4> order =
        arm ? std::array{R::UpperArm, R::Forearm, R::Hand, R::Finger} : std::array{R::Thigh, R::Calf, R::Foot, R::Toe};
    // The chain, whether it branches, and whether the limb names its other parts.
    std::vector<std::size_t> chain{start};
    bool branched = false;
    for (;;) {
      std::size_t next = J, count = 0;
      for (const std::size_t c : children[chain.back()])
        if (named[c] == role) {
          next = c;
          ++count;
        }
      branched = count > 1;
      if (count != 1 || chain.size() == J) break;
      chain.push_back(next);
    }
    const auto other_part = [&](std::size_t j) {
      return named[j] != role && std::find(order.begin(), order.end(), named[j]) != order.end();
    };
    bool specific = false;
    std::int32_t a = parents[start];
    for (std::size_t steps = 0; a >= 0 && static_cast<std::size_t>(a) < J && steps < J && !specific; ++steps) {
      specific = other_part(static_cast<std::size_t>(a));
      a = parents[static_cast<std::size_t>(a)];
    }
    std::vector<std::size_t> stack{start};
    for (std::size_t visited = 0; !stack.empty() && !specific && visited <= J; ++visited) {
      const std::size_t j = stack.back();
      stack.pop_back();
      specific = other_part(j);
      stack.insert(stack.end(), children[j].begin(), children[j].end());
    }
    if (chain.size() < 2 || branched || specific) continue;
    for (std::size_t k = 0; k < chain.size(); ++k) roles[chain[k]] = order[std::min<std::size_t>(k, order.size() - 1)];
  }
  // The interphalangeal joints: a finger joint below another finger joint.
  const std::vector<JointRole> limbs(roles.begin(), roles.end());
  for (std::size_t j = 0; j < J; ++j) {
    const auto p = static_cast<std::size_t>(parents[j]);
    if (limbs[j] == JointRole::Finger && parents[j] >= 0 && p < J && limbs[p] == JointRole::Finger)
      roles[j] = JointRole::FingerHinge;
  }
}

JointSide joint_side(std::string_view name) {
  const std::string w = words(name);
  if (has(w, " left ") || has(w, " l ")) return JointSide::Left;
  if (has(w, " right ") || has(w, " r ")) return JointSide::Right;
  return JointSide::None;
}

bool is_thumb(std::string_view name) {
  const std::string w = words(name);
  // 3ds Max Biped numbers the fingers from the thumb: "Finger0", then "Finger01", "Finger02".
  return has(w, "thumb") || has(w, " finger0 ") || has(w, " finger01 ") || has(w, " finger02 ");
}

std::optional<RoleMotion> role_motion(JointRole role) {
  using D = BodyDirection;
  // {twist, {{towards, lo, hi}, {towards, lo, hi}}}, radians.
  switch (role) {
    case JointRole::Unknown:
    case JointRole::Hips:
    case JointRole::End: return std::nullopt;
    case JointRole::Spine: return RoleMotion{0.25f, {{{D::Forward, -0.2f, 0.35f}, {D::Left, -0.2f, 0.2f}}}};
    case JointRole::Neck: return RoleMotion{0.5f, {{{D::Forward, -0.3f, 0.4f}, {D::Left, -0.3f, 0.3f}}}};
    case JointRole::Head: return RoleMotion{0.4f, {{{D::Forward, -0.3f, 0.35f}, {D::Left, -0.25f, 0.25f}}}};
    case JointRole::Clavicle: return RoleMotion{0.1f, {{{D::Up, -0.15f, 0.3f}, {D::Forward, -0.25f, 0.25f}}}};
    // The arm lowers by up to 1.2 rad from a T-pose (pose_space stops it 0.35 rad short of
    // hanging straight down) and raises 0.5.
    case JointRole::UpperArm: return RoleMotion{0.7f, {{{D::Forward, -0.6f, 1.2f}, {D::Up, -1.2f, 0.5f}}}};
    case JointRole::Forearm: return RoleMotion{0.8f, {{{D::Forward, 0.0f, 1.4f}, {D::Up, -0.05f, 0.05f}}}};
    // The wrist bends both ways as far. Fingers curl towards the palm; a knuckle spreads a little,
    // the joints beyond it only curl.
    case JointRole::Hand: return RoleMotion{0.1f, {{{D::Up, -0.6f, 0.6f}, {D::Forward, -0.3f, 0.3f}}}};
    case JointRole::Finger: return RoleMotion{0.05f, {{{D::Palm, -0.2f, 0.8f}, {D::Forward, -0.15f, 0.15f}}}};
    case JointRole::FingerHinge: return RoleMotion{0.0f, {{{D::Palm, 0.0f, 1.0f}, {D::Forward, 0.0f, 0.0f}}}};
    case JointRole::Thigh: return RoleMotion{0.5f, {{{D::Forward, -0.5f, 1.2f}, {D::Medial, -0.6f, 0.2f}}}};
    case JointRole::Calf: return RoleMotion{0.15f, {{{D::Forward, -1.4f, 0.0f}, {D::Medial, -0.05f, 0.05f}}}};
    case JointRole::Foot: return RoleMotion{0.1f, {{{D::Up, -0.5f, 0.35f}, {D::Medial, -0.25f, 0.25f}}}};
    case JointRole::Toe: return RoleMotion{0.05f, {{{D::Up, -0.3f, 0.5f}, {D::Medial, -0.05f, 0.05f}}}};
  }
  return std::nullopt;
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Glob match with '*' only, iterative with one backtrack point (linear in practice).
bool glob(std::string_view p, std::string_view s) {
  std::size_t i = 0, j = 0, star = std::string_view::npos, mark = 0;
  while (j < s.size()) {
    if (i < p.size() && p[i] == '*') {
      star = i++;
      mark = j;
    } else if (i < p.size() && p[i] == s[j]) {
      ++i;
      ++j;
    } else if (star != std::string_view::npos) {
      i = star + 1;
      j = ++mark;
    } else {
      return false;
    }
  }
  while (i < p.size() && p[i] == '*') ++i;
  return i == p.size();
}

}  // namespace

Result<std::vector<JointLimit>> parse_joint_limits(std::string_view text) {
  std::vector<JointLimit> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find_first_of(",;", start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view entry = trim(text.substr(start, end - start));
    start = end + 1;
    if (entry.empty()) continue;
    const auto bad = [&](const std::string& why) {
      return make_error(ErrorCode::InvalidArgument, "joint_limits entry '" + std::string(entry) + "': " + why +
                                                        "; write PATTERN=RADIANS, e.g. 'LeftForeArm=1.2, *Spine*=0.3'");
    };
    const std::size_t eq = entry.rfind('=');
    if (eq == std::string_view::npos) return bad("has no '='");
    JointLimit limit;
    limit.pattern = std::string(trim(entry.substr(0, eq)));
    if (limit.pattern.empty()) return bad("has no joint name before '='");
    const std::string number(trim(entry.substr(eq + 1)));
    // from_chars: the C locale's '.', whatever the process's locale.
    double value = -1.0;
    const auto [stop, error] = std::from_chars(number.data(), number.data() + number.size(), value);
    if (number.empty() || error != std::errc() || stop != number.data() + number.size() ||
        !(value >= 0.0 && value <= std::numbers::pi))
      return bad("'" + number + "' is not a limit in 0..3.1416 radians");
    limit.limit = static_cast<float>(value);
    out.push_back(std::move(limit));
  }
  return out;
}

bool joint_name_matches(std::string_view pattern, std::string_view name) {
  return glob(pattern, name) || glob(pattern, name_without_namespace(name));
}

}  // namespace penumbra
