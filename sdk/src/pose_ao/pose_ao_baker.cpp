// The pose-AO bake (Kontkanen & Aila 2006, "Ambient Occlusion for Animated Characters"; the
// thesis, section 4.2): reference poses, ray-traced self-occlusion per posed mesh, per-vertex
// ridge regression, and the PSAO chunk (see pose_ao_baker.h).
#include "penumbra/pose_ao/pose_ao_baker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_map>

#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/log.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/pose_ao/joint_roles.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/entity_key.h"
#include "penumbra/scene/mesh.h"
#include "ridge.h"

namespace penumbra {

namespace {

constexpr std::uint64_t kPoseStreamTag = 0x706f7365616f5f70ull;  // random poses
constexpr std::uint64_t kRayStreamTag = 0x7261795f73636d62ull;   // ray scrambles

bool finite_matrix(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k)
      if (!std::isfinite(m[c][k])) return false;
  return true;
}

// TRS of an affine matrix without shear (columns' lengths are the scale).
Transform decompose(const glm::mat4& m) {
  Transform t;
  t.translation = glm::vec3(m[3]);
  glm::mat3 r(m);
  for (int c = 0; c < 3; ++c) {
    t.scale[c] = glm::length(r[c]);
    r[c] = t.scale[c] > 0.0f ? r[c] / t.scale[c] : glm::vec3(0.0f);
  }
  t.rotation = glm::normalize(glm::quat_cast(r));
  return t;
}

// Rotation vector (axis x angle) of a unit quaternion, angle in [0, pi].
glm::vec3 rotation_vector(glm::quat q) {
  if (q.w < 0.0f) q = -q;
  const glm::vec3 v(q.x, q.y, q.z);
  const float s = glm::length(v);
  if (s < 1e-12f) return 2.0f * v;
  return v * (2.0f * std::atan2(s, q.w) / s);
}

glm::quat rotation_from_vector(glm::vec3 r) {
  const float angle = glm::length(r);
  if (angle < 1e-12f) return glm::normalize(glm::quat(1.0f, 0.5f * r.x, 0.5f * r.y, 0.5f * r.z));
  return glm::angleAxis(angle, r / angle);
}

std::string entity_context(World& world, Entity e) {
  const Name* name = world.try_get<Name>(e);
  return "pose-AO " + (name ? "'" + name->value + "' " : std::string()) + "(entity " + std::to_string(e.index) + ")";
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Step 1: the rig.

Result<PoseRig> make_pose_rig(World& world, Entity e, std::string_view context) {
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": " + what);
  };
  const Skin* skin = world.alive(e) ? world.try_get<Skin>(e) : nullptr;
  const WorldTransform* mesh_world = world.alive(e) ? world.try_get<WorldTransform>(e) : nullptr;
  if (skin == nullptr || mesh_world == nullptr)
    return bad("needs a Skin and a WorldTransform (run the transform system before baking)");
  const std::size_t joints = skin->joints.size();
  if (joints == 0 || joints > 65535 || skin->inverse_bind.size() != joints)
    return bad("the skin has " + std::to_string(joints) + " joints and " + std::to_string(skin->inverse_bind.size()) +
               " inverse bind matrices; re-export the skin with 1..65535 joints, one matrix each");

  std::unordered_map<std::uint32_t, std::uint32_t> joint_of;  // entity index -> skin joint
  for (std::size_t j = 0; j < joints; ++j) joint_of.emplace(skin->joints[j].index, static_cast<std::uint32_t>(j));
  const auto joint_index = [&](Entity x) -> std::int32_t {
    const auto it = joint_of.find(x.index);
    return it != joint_of.end() && skin->joints[it->second] == x ? static_cast<std::int32_t>(it->second) : -1;
  };

  PoseRig rig;
  rig.parents.assign(joints, -1);
  rig.offsets.resize(joints);
  rig.inverse_bind = skin->inverse_bind;
  for (std::size_t j = 0; j < joints; ++j) {
    const Entity je = skin->joints[j];
    if (!world.alive(je) || !world.has<Transform>(je) || !world.has<WorldTransform>(je))
      return bad("joint " + std::to_string(j) + " has no Transform/WorldTransform (a stale joint entity?)");
    const Name* name = world.try_get<Name>(je);
    rig.names.push_back(name ? name->value : std::string());
    const Parent* parent = world.try_get<Parent>(je);
    const Entity parent_node = parent ? parent->entity : Entity::null();
    // The nearest ancestor that is a joint of this skin.
    for (Entity a = parent_node; a && world.alive(a);) {
      if (const std::int32_t pj = joint_index(a); pj >= 0) {
        rig.parents[j] = pj;
        break;
      }
      const Parent* up = world.try_get<Parent>(a);
      a = up ? up->entity : Entity::null();
    }
    const glm::mat4 anchor = rig.parents[j] >= 0
                                 ? world.get<WorldTransform>(skin->joints[static_cast<std::size_t>(rig.parents[j])]).matrix
                                 : mesh_world->matrix;
    const WorldTransform* pw = parent_node && world.alive(parent_node) ? world.try_get<WorldTransform>(parent_node) : nullptr;
    rig.offsets[j] = glm::inverse(anchor) * (pw ? pw->matrix : glm::mat4(1.0f));
    if (!finite_matrix(rig.offsets[j])) return bad("joint " + std::to_string(j) + ": a singular node transform");
  }

  // Joints with parents first (depth-first from the roots); a parent cycle cannot occur in a
  // hierarchy, but guard the walk anyway.
  std::vector<std::uint8_t> placed(joints, 0);
  while (rig.order.size() < joints) {
    const std::size_t before = rig.order.size();
    for (std::size_t j = 0; j < joints; ++j)
      if (!placed[j] && (rig.parents[j] < 0 || placed[static_cast<std::size_t>(rig.parents[j])])) {
        placed[j] = 1;
        rig.order.push_back(static_cast<std::uint32_t>(j));
      }
    if (rig.order.size() == before) return bad("the joints' parents form a cycle");
  }

  // Bind pose: X_j,bind = inverse(inverse_bind_j) in the mesh frame; local = offset^-1 X_p^-1 X_j.
  std::vector<glm::mat4> bind_world(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    const glm::mat4& ib = skin->inverse_bind[j];
    const float det = glm::determinant(glm::mat3(ib));
    if (!finite_matrix(ib) || !(std::abs(det) > 1e-30f))
      return bad("inverse bind matrix " + std::to_string(j) + " is singular or not finite; re-export the skin");
    bind_world[j] = glm::inverse(ib);
  }
  rig.bind.resize(joints);
  rig.bind_positions.resize(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    const glm::mat4 parent_world =
        rig.parents[j] >= 0 ? bind_world[static_cast<std::size_t>(rig.parents[j])] : glm::mat4(1.0f);
    rig.bind[j] = decompose(glm::inverse(rig.offsets[j]) * glm::inverse(parent_world) * bind_world[j]);
    rig.bind_positions[j] = glm::vec3(bind_world[j][3]);
  }

  // Clips: those of every Animator (in entity order) with a channel on a joint of this skin.
  for (Entity a : world.view<Animator>().sorted_entities()) {
    const Animator& animator = world.get<Animator>(a);
    if (!animator.clips) continue;
    for (const AnimationClip& clip : *animator.clips) {
      if (std::find(rig.clips.begin(), rig.clips.end(), &clip) != rig.clips.end()) continue;
      std::vector<std::pair<std::uint32_t, std::uint32_t>> channels;
      for (std::size_t c = 0; c < clip.channels.size(); ++c) {
        const AnimationChannel& ch = clip.channels[c];
        if (ch.target >= clip.targets.size() || ch.times.empty()) continue;
        if (const std::int32_t j = joint_index(clip.targets[ch.target]); j >= 0)
          channels.emplace_back(static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(j));
      }
      if (channels.empty()) continue;
      rig.clips.push_back(&clip);
      rig.clip_channels.push_back(std::move(channels));
    }
  }

  // Rotation ranges seen in the clips: 64 uniform times per clip plus every key time.
  rig.clip_ranges.assign(joints, JointRange{glm::vec3(std::numeric_limits<float>::max()),
                                            glm::vec3(-std::numeric_limits<float>::max())});
  std::vector<std::uint8_t> seen(joints, 0);
  for (std::size_t c = 0; c < rig.clips.size(); ++c) {
    std::vector<float> times;
    for (int k = 0; k <= 64; ++k) times.push_back(rig.clips[c]->duration * static_cast<float>(k) / 64.0f);
    for (const auto& [channel, joint] : rig.clip_channels[c])
      for (float t : rig.clips[c]->channels[channel].times) times.push_back(t);
    for (float t : times) {
      const Pose pose = clip_pose(rig, c, t);
      for (const auto& [channel, joint] : rig.clip_channels[c]) {
        if (rig.clips[c]->channels[channel].path != AnimationChannel::Path::Rotation) continue;
        const glm::vec3 r = rotation_vector(glm::conjugate(rig.bind[joint].rotation) * pose[joint].rotation);
        rig.clip_ranges[joint].min = glm::min(rig.clip_ranges[joint].min, r);
        rig.clip_ranges[joint].max = glm::max(rig.clip_ranges[joint].max, r);
        seen[joint] = 1;
      }
    }
  }
  rig.animated.assign(joints, false);
  for (std::size_t j = 0; j < joints; ++j) {
    if (!seen[j]) {
      rig.clip_ranges[j] = JointRange{};
      continue;
    }
    const glm::vec3 width = rig.clip_ranges[j].max - rig.clip_ranges[j].min;
    rig.animated[j] = std::max({width.x, width.y, width.z}) > 1e-6f;
  }
  return rig;
}

namespace {

float width(const JointRange& r) { return std::max({r.max.x - r.min.x, r.max.y - r.min.y, r.max.z - r.min.z}); }

// The direction of each finger's palm (BodyDirection::Palm) in the bind pose, per hand: normal to
// the plane of its knuckles' bones and the line across them, on the side where the thumb lies
// (the thumb sits on the palm's side of the knuckles). Found for the fingers, not the thumb (it
// curls across the palm), of a hand with a thumb and two other fingers whose knuckles span a
// line, and a thumb off that plane by a tenth of the line; nullopt elsewhere. A finger's hand: the
// topmost of the Hand joints above its Finger and FingerHinge joints (a metacarpal is a Hand).
// bones[j]: joint j's unit bone direction in the bind pose, zero where it has none; height: the
// body's, for the knuckles' least span.
std::vector<std::optional<glm::vec3>> palms(const PoseRig& rig, std::span<const JointRole> roles,
                                            std::span<const glm::vec3> bones, float height) {
  const std::size_t J = rig.joint_count();
  std::vector<std::optional<glm::vec3>> out(J);
  const auto is_finger = [&](std::size_t j) { return roles[j] == JointRole::Finger || roles[j] == JointRole::FingerHinge; };
  const auto parent_of = [&](std::size_t j) {
    return rig.parents[j] >= 0 && static_cast<std::size_t>(rig.parents[j]) < J ? static_cast<std::size_t>(rig.parents[j]) : J;
  };
  std::vector<std::size_t> hand(J, J);
  for (std::size_t j = 0; j < J; ++j) {
    if (!is_finger(j)) continue;
    std::size_t a = j;
    for (std::size_t steps = 0; a < J && is_finger(a) && steps < J; ++steps) a = parent_of(a);
    for (std::size_t steps = 0; a < J && roles[a] == JointRole::Hand && steps < J; ++steps) {
      hand[j] = a;
      a = parent_of(a);
    }
  }
  std::vector<bool> thumb(J);
  for (std::size_t j = 0; j < J && j < rig.names.size(); ++j) thumb[j] = is_thumb(rig.names[j]);
  for (std::size_t h = 0; h < J; ++h) {
    if (roles[h] != JointRole::Hand) continue;
    // The knuckles (Finger joints) of the hand's fingers, their bones' mean direction, the thumb's joints.
    std::vector<std::size_t> knuckles;
    glm::vec3 along(0.0f), thumb_sum(0.0f);
    int thumb_joints = 0;
    for (std::size_t j = 0; j < J; ++j) {
      if (hand[j] != h) continue;
      if (thumb[j]) {
        thumb_sum += rig.bind_positions[j];
        ++thumb_joints;
        continue;
      }
      if (roles[j] != JointRole::Finger || bones[j] == glm::vec3(0.0f)) continue;
      knuckles.push_back(j);
      along += bones[j];
    }
    if (knuckles.size() < 2 || thumb_joints == 0 || !(glm::length(along) > 0.5f * float(knuckles.size()))) continue;
    along = glm::normalize(along);
    glm::vec3 across(0.0f), centre(0.0f);
    for (const std::size_t a : knuckles) {
      centre += rig.bind_positions[a] / float(knuckles.size());
      for (const std::size_t b : knuckles) {
        const glm::vec3 d = rig.bind_positions[a] - rig.bind_positions[b];
        if (glm::length(d) > glm::length(across)) across = d;
      }
    }
    const float span = glm::length(across);
    across -= glm::dot(across, along) * along;
    if (!(glm::length(across) > 0.5f * span && span > 1e-4f * height)) continue;
    glm::vec3 normal = glm::normalize(glm::cross(along, across));
    const float offset = glm::dot(normal, thumb_sum / float(thumb_joints) - centre);
    if (!(std::abs(offset) > 0.1f * span)) continue;
    if (offset < 0.0f) normal = -normal;
    for (std::size_t j = 0; j < J; ++j)
      if (hand[j] == h && !thumb[j]) out[j] = normal;
  }
  return out;
}

// Each joint's range from its role's motion (role_motion) about its bone, in its bind frame: a box
// in the frame's axes where the twist and swing axes each lie within 37 degrees of one, else a box
// in axes of its own (JointRange::axes); nullopt where that cannot be placed: a role without a
// motion, no body frame (no head, neck or spine above the hips, no joints named on both sides), a
// bone of no length, a medial swing on the midline, a swing towards the bone, or a second swing
// axis more than 37 degrees off the perpendicular of the bone and the first. The body frame: up
// from the hips to the head (else the neck, else the spine), left from the right-side joints to
// the left-side ones, forward = left x up.
std::vector<std::optional<JointRange>> anatomical_ranges(const PoseRig& rig, std::span<const JointRole> roles) {
  const std::size_t J = rig.joint_count();
  std::vector<std::optional<JointRange>> out(J);
  const auto mean_of = [&](auto&& pick) -> std::optional<glm::vec3> {
    glm::vec3 sum(0.0f);
    int n = 0;
    for (std::size_t j = 0; j < J; ++j)
      if (pick(j)) {
        sum += rig.bind_positions[j];
        ++n;
      }
    return n > 0 ? std::optional<glm::vec3>(sum / float(n)) : std::nullopt;
  };
  const auto role_is = [&](JointRole r) { return [&, r](std::size_t j) { return roles[j] == r; }; };
  std::optional<glm::vec3> hips = mean_of(role_is(JointRole::Hips));
  if (!hips) hips = mean_of([&](std::size_t j) { return rig.parents[j] < 0; });
  std::optional<glm::vec3> head = mean_of(role_is(JointRole::Head));
  if (!head) head = mean_of(role_is(JointRole::Neck));
  if (!head) head = mean_of(role_is(JointRole::Spine));
  std::vector<JointSide> sides(J, JointSide::None);
  for (std::size_t j = 0; j < J && j < rig.names.size(); ++j) sides[j] = joint_side(rig.names[j]);
  const std::optional<glm::vec3> left = mean_of([&](std::size_t j) { return sides[j] == JointSide::Left; });
  const std::optional<glm::vec3> right = mean_of([&](std::size_t j) { return sides[j] == JointSide::Right; });
  if (!hips || !head || !left || !right) return out;
  const float height = glm::length(*head - *hips);
  if (!(height > 0.0f)) return out;
  const glm::vec3 up = (*head - *hips) / height;
  glm::vec3 side = *left - *right;
  side -= glm::dot(side, up) * up;
  if (!(glm::length(side) > 1e-3f * height)) return out;
  side = glm::normalize(side);
  const glm::vec3 forward = glm::cross(side, up);

  // The frame each joint's rotation vector lives in (bind_rotation x exp(r)): the parent's world
  // transform, the offset and the bind rotation, without the joint's own scale.
  std::vector<glm::mat4> world(J, glm::mat4(1.0f));
  std::vector<glm::mat3> frame(J, glm::mat3(1.0f));
  std::vector<std::vector<std::uint32_t>> children(J);
  for (const std::uint32_t j : rig.order) {
    const glm::mat4 parent = rig.parents[j] >= 0 ? world[static_cast<std::size_t>(rig.parents[j])] : glm::mat4(1.0f);
    world[j] = parent * rig.offsets[j] * rig.bind[j].matrix();
    frame[j] = glm::mat3(parent * rig.offsets[j]) * glm::mat3_cast(rig.bind[j].rotation);
    if (rig.parents[j] >= 0) children[static_cast<std::size_t>(rig.parents[j])].push_back(j);
  }
  // Each joint's bone: to the mean of its children, or on from the parent for a joint without any;
  // zero where that is shorter than 1e-4 of the body's height.
  std::vector<glm::vec3> bones(J, glm::vec3(0.0f));
  for (std::size_t j = 0; j < J; ++j) {
    glm::vec3 bone(0.0f);
    for (const std::uint32_t c : children[j]) bone += rig.bind_positions[c] - rig.bind_positions[j];
    if (!(glm::length(bone) > 1e-4f * height) && rig.parents[j] >= 0)
      bone = rig.bind_positions[j] - rig.bind_positions[static_cast<std::size_t>(rig.parents[j])];
    if (glm::length(bone) > 1e-4f * height) bones[j] = glm::normalize(bone);
  }
  const std::vector<std::optional<glm::vec3>> palm = palms(rig, roles, bones, height);
  for (std::size_t j = 0; j < J; ++j) {
    const std::optional<RoleMotion> motion = role_motion(roles[j]);
    if (!motion || !(glm::determinant(frame[j]) > 0.0f) || bones[j] == glm::vec3(0.0f)) continue;
    const glm::vec3 bone = bones[j];
    const glm::mat3 to_local = glm::inverse(frame[j]);
    // The frame axis a direction lies along (with its sign), or -1 when none is within 37 degrees.
    const auto snap = [&](glm::vec3 v, float& sign) {
      const glm::vec3 l = glm::normalize(to_local * v);
      for (int k = 0; k < 3; ++k)
        if (std::abs(l[k]) >= 0.8f) {
          sign = l[k] > 0.0f ? 1.0f : -1.0f;
          return k;
        }
      return -1;
    };
    // Each swing's direction and interval: the palm's side where it is known (else up, the interval
    // made symmetric), the midline's side for the joint's side of the body, and an upper arm
    // lowered to 0.35 rad short of straight down (it hangs, it does not enter the body).
    struct Resolved {
      glm::vec3 axis;  // bone x towards
      float lo, hi;
    };
    std::array<Resolved, 2> swings{};
    bool resolved = true;
    for (std::size_t i = 0; i < 2 && resolved; ++i) {
      const RoleMotion::Swing& s = motion->swings[i];
      glm::vec3 towards = s.towards == BodyDirection::Forward ? forward : s.towards == BodyDirection::Up ? up : side;
      float lo = s.lo, hi = s.hi;
      if (s.towards == BodyDirection::Palm) {
        towards = palm[j] ? *palm[j] : up;
        if (!palm[j]) lo = -(hi = 0.5f * (s.hi - s.lo));
      }
      if (s.towards == BodyDirection::Medial) {
        resolved = sides[j] != JointSide::None;
        towards = sides[j] == JointSide::Left ? -side : side;
      }
      if (s.towards == BodyDirection::Up && roles[j] == JointRole::UpperArm)
        lo = std::max(lo, std::min(0.0f, 0.35f - std::acos(std::clamp(-glm::dot(bone, up), -1.0f, 1.0f))));
      swings[i] = Resolved{glm::cross(bone, towards), lo, hi};
      resolved = resolved && glm::length(swings[i].axis) > 0.3f;
    }
    if (!resolved) continue;
    // The range as a box in the joint's own frame, each axis within 37 degrees of the twist or a
    // swing axis.
    float twist_sign = 1.0f;
    const int twist_axis = snap(bone, twist_sign);
    JointRange range;
    std::array<bool, 3> used{};
    bool placed = twist_axis >= 0;
    if (placed) {
      used[static_cast<std::size_t>(twist_axis)] = true;
      range.min[twist_axis] = -motion->twist;
      range.max[twist_axis] = motion->twist;
    }
    for (const Resolved& s : swings) {
      if (!placed) break;
      float sign = 1.0f;
      const int k = snap(s.axis, sign);
      if (k < 0 || used[static_cast<std::size_t>(k)]) {
        placed = false;
        break;
      }
      used[static_cast<std::size_t>(k)] = true;
      range.min[k] = sign > 0.0f ? s.lo : -s.hi;
      range.max[k] = sign > 0.0f ? s.hi : -s.lo;
    }
    if (placed) {
      out[j] = range;
      continue;
    }
    // Else a box in a frame of its own (JointRange::axes): x along the bone, y the first swing's
    // axis, z = x cross y, which the second swing's axis must lie within 37 degrees of.
    const glm::vec3 e0 = bone, e1 = glm::normalize(swings[0].axis), e2 = glm::cross(e0, e1);
    const float along = glm::dot(glm::normalize(swings[1].axis), e2);
    if (!(std::abs(along) >= 0.8f)) continue;
    // The frame in the joint's local axes (to_local may scale: an armature's 0.01), orthonormal.
    glm::mat3 axes(to_local * e0, to_local * e1, glm::vec3(0.0f));
    axes[0] = glm::normalize(axes[0]);
    axes[1] = glm::normalize(axes[1] - glm::dot(axes[1], axes[0]) * axes[0]);
    axes[2] = glm::cross(axes[0], axes[1]);
    range.axes = glm::normalize(glm::quat_cast(axes));
    range.min = glm::vec3(-motion->twist, swings[0].lo, along > 0.0f ? swings[1].lo : -swings[1].hi);
    range.max = glm::vec3(motion->twist, swings[0].hi, along > 0.0f ? swings[1].hi : -swings[1].lo);
    out[j] = range;
  }
  return out;
}

}  // namespace

PoseSpace pose_space(const PoseRig& rig, const SkinnedPoseAO& settings) {
  using PoseSource = SkinnedPoseAO::PoseSource;
  PoseSpace space;
  const std::size_t J = rig.joint_count();
  const JointRange around_bind{glm::vec3(-settings.default_range), glm::vec3(settings.default_range)};
  // Ranges by role (joint_roles.h); joints of no known role get +-default_range.
  std::vector<JointRole> roles(J, JointRole::Unknown);
  for (std::size_t j = 0; j < J && j < rig.names.size(); ++j) roles[j] = joint_role(rig.names[j]);
  assign_chain_roles(rig.parents, roles);
  const std::size_t known_roles =
      J - static_cast<std::size_t>(std::count(roles.begin(), roles.end(), JointRole::Unknown));
  const auto by_role = [&] {
    const std::vector<std::optional<JointRange>> anatomical = anatomical_ranges(rig, roles);
    for (std::size_t j = 0; j < J; ++j) {
      const float limit = role_limit(roles[j], settings.default_range);
      space.ranges[j] = anatomical[j] ? *anatomical[j] : JointRange{glm::vec3(-limit), glm::vec3(limit)};
      space.anatomical += anatomical[j].has_value();
    }
    space.roles = known_roles;
  };
  space.ranges.assign(J, JointRange{});
  if (!settings.joint_ranges.empty()) {
    space.source = PoseSpace::Source::JointRanges;
    space.ranges = settings.joint_ranges;
  } else if (settings.pose_source == PoseSource::Uniform ||
             (rig.clips.empty() && (settings.pose_source == PoseSource::Clips || known_roles == 0))) {
    space.source = PoseSpace::Source::Default;
    space.ranges.assign(J, around_bind);
  } else if (settings.pose_source == PoseSource::Roles || rig.clips.empty()) {
    space.source = PoseSpace::Source::Roles;
    by_role();
  } else {
    space.source = PoseSpace::Source::Clips;
    for (std::size_t j = 0; j < J; ++j) {
      if (!rig.animated[j]) continue;  // fixed: zero range about the bind rotation
      const JointRange& c = rig.clip_ranges[j];
      space.clip_widest_range = std::max(space.clip_widest_range, width(c));
      const glm::vec3 widen = settings.range_margin * (c.max - c.min);
      space.ranges[j] = JointRange{c.min - widen, c.max + widen};
    }
    if (std::none_of(space.ranges.begin(), space.ranges.end(),
                     [](const JointRange& r) { return width(r) > kPoseMinJointRange; })) {
      // Step 1 (thesis 4.5 trains on poses that span the motion): clips that barely move give a
      // space of one pose, so the joints get the ranges of their roles when their names give
      // roles, else the joints the clips animate get the range a clip-less rig gets.
      if (settings.pose_source == PoseSource::Auto && known_roles > 0) {
        space.source = PoseSpace::Source::DegenerateClipsRoles;
        by_role();
      } else {
        space.source = PoseSpace::Source::DegenerateClips;
        const bool any = std::find(rig.animated.begin(), rig.animated.end(), true) != rig.animated.end();
        for (std::size_t j = 0; j < J; ++j)
          if (!any || rig.animated[j]) space.ranges[j] = around_bind;
      }
    }
  }
  // Limits by name over what the source gave (the last matching entry wins).
  if (settings.joint_ranges.empty()) {
    auto parsed = parse_joint_limits(settings.joint_limits);
    const std::vector<JointLimit> limits = parsed ? std::move(*parsed) : std::vector<JointLimit>{};
    std::vector<std::uint8_t> limited(J, 0);
    for (const JointLimit& l : limits) {
      bool matched = false;
      for (std::size_t j = 0; j < J && j < rig.names.size(); ++j)
        if (joint_name_matches(l.pattern, rig.names[j])) {
          space.ranges[j] = JointRange{glm::vec3(-l.limit), glm::vec3(l.limit)};
          limited[j] = 1;
          matched = true;
        }
      if (!matched) space.unmatched_limits.push_back(l.pattern);
    }
    space.limited = static_cast<std::size_t>(std::count(limited.begin(), limited.end(), 1));
  }
  // On the ground a root's rotation would tilt the whole character against the floor, which no
  // joint of the model explains (roots are never in a locality): roots stay at bind.
  if (settings.ground)
    for (std::size_t j = 0; j < space.ranges.size() && j < rig.parents.size(); ++j)
      if (rig.parents[j] < 0) space.ranges[j] = JointRange{};
  for (std::size_t j = 0; j < space.ranges.size(); ++j) {
    const float w = width(space.ranges[j]);
    space.moving += w > kPoseMinJointRange;
    if (w > space.widest_range) {
      space.widest_range = w;
      space.widest = j;
    }
  }
  return space;
}

// ---------------------------------------------------------------------------------------------
// Step 2: poses.

Pose random_pose(const PoseRig& rig, std::span<const JointRange> ranges, std::uint64_t seed, std::uint64_t index) {
  Rng rng = Rng::stream(seed ^ kPoseStreamTag, index);
  Pose pose = rig.bind;
  for (std::size_t j = 0; j < pose.size(); ++j) {
    glm::vec3 r;
    for (int a = 0; a < 3; ++a) r[a] = ranges[j].min[a] + (ranges[j].max[a] - ranges[j].min[a]) * rng.next_float();
    glm::quat turn = rotation_from_vector(r);
    const glm::quat& axes = ranges[j].axes;
    if (axes != glm::quat(1.0f, 0.0f, 0.0f, 0.0f)) turn = axes * turn * glm::conjugate(axes);
    pose[j].rotation = glm::normalize(rig.bind[j].rotation * turn);
  }
  return pose;
}

Pose clip_pose(const PoseRig& rig, std::size_t clip, float t) {
  Pose pose = rig.bind;
  const AnimationClip& c = *rig.clips[clip];
  t = std::clamp(t, 0.0f, std::max(c.duration, 0.0f));
  for (const auto& [channel, joint] : rig.clip_channels[clip]) {
    const AnimationChannel& ch = c.channels[channel];
    const glm::vec4 v = sample_channel(ch, t);
    switch (ch.path) {
      case AnimationChannel::Path::Translation: pose[joint].translation = glm::vec3(v); break;
      case AnimationChannel::Path::Rotation: pose[joint].rotation = glm::quat(v.w, v.x, v.y, v.z); break;
      case AnimationChannel::Path::Scale: pose[joint].scale = glm::vec3(v); break;
    }
  }
  return pose;
}

std::vector<glm::mat4> skinning_matrices(const PoseRig& rig, const Pose& pose) {
  std::vector<glm::mat4> world(rig.joint_count()), out(rig.joint_count());
  for (std::uint32_t j : rig.order) {
    const glm::mat4 parent = rig.parents[j] >= 0 ? world[static_cast<std::size_t>(rig.parents[j])] : glm::mat4(1.0f);
    world[j] = parent * rig.offsets[j] * pose[j].matrix();
    out[j] = world[j] * rig.inverse_bind[j];
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Step 3: ray-traced self-occlusion of the posed mesh.

// The traced mesh's vertices come first in the ray scene's mesh, then the occluders'. Joint
// slots of the scene's skin: the J joints of the traced skin, the identity (the traced mesh's
// weightless vertices), then per occluder one slot per joint of its skin (M_j x to_traced[k])
// and one for its weightless vertices (the fixed `rigid`).
struct PoseAOTracer::Impl {
  std::shared_ptr<const MeshData> mesh;  // the traced mesh then the occluders, remapped as above
  std::size_t joints = 0;
  std::size_t vertices = 0;              // the traced mesh's
  std::vector<PoseAOOccluder> occluders;
  std::unique_ptr<World> world;          // the character's meshes, skinned, refitted per pose
  Entity entity;
  std::optional<RayScene> scene;
  float eps_scale = 0.0f;                // 1e-4 x the bind bounds' diagonal
  std::vector<glm::vec3> positions, normals;
  std::string context;
};

PoseAOTracer::PoseAOTracer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PoseAOTracer::PoseAOTracer(PoseAOTracer&&) noexcept = default;
PoseAOTracer& PoseAOTracer::operator=(PoseAOTracer&&) noexcept = default;
PoseAOTracer::~PoseAOTracer() = default;
std::size_t PoseAOTracer::vertex_count() const { return impl_->vertices; }
std::size_t PoseAOTracer::occluder_count() const { return impl_->occluders.size(); }

Result<PoseAOTracer> PoseAOTracer::create(std::shared_ptr<const MeshData> source, std::size_t joint_count,
                                          std::string_view context, std::vector<PoseAOOccluder> occluders) {
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": " + what);
  };
  if (!source || source->positions.empty() || source->indices.empty()) return bad("the mesh is empty");
  const std::size_t n = source->positions.size();
  if (source->normals.size() != n) return bad("the mesh has no normals; import computes them, re-import it");
  if (source->joints.size() != n || source->weights.size() != n)
    return bad("the mesh has no JOINTS_0/WEIGHTS_0; pose-AO needs a skinned mesh");
  auto mesh = std::make_shared<MeshData>(*source);
  for (std::size_t v = 0; v < n; ++v) {
    bool weighted = false;
    for (int k = 0; k < 4; ++k) {
      if (mesh->weights[v][k] == 0.0f) continue;
      if (mesh->joints[v][k] >= joint_count)
        return bad("vertex " + std::to_string(v) + " uses joint " + std::to_string(mesh->joints[v][k]) +
                   " but the skin has " + std::to_string(joint_count) + "; re-export the skin");
      weighted = true;
    }
    // A vertex without weights follows the mesh frame: bind it to the extra identity joint.
    if (!weighted) {
      mesh->joints[v] = glm::u16vec4(static_cast<std::uint16_t>(joint_count), 0, 0, 0);
      mesh->weights[v] = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
    }
  }
  // The occluders' vertices and triangles after the traced mesh's, on their own joint slots.
  std::size_t slot = joint_count + 1;
  for (const PoseAOOccluder& o : occluders) {
    if (!o.mesh) return bad("an occluder has no mesh");
    const MeshData& m = *o.mesh;
    const std::size_t k_count = o.joints.size();
    if (o.to_traced.size() != k_count || m.joints.size() != m.positions.size() ||
        m.weights.size() != m.positions.size())
      return bad("occluder '" + m.name + "' has no skinning for its joints; re-export it");
    if (slot + k_count + 1 > 65535)
      return bad("the character's meshes use more than 65535 joint slots together; trace fewer meshes with it");
    for (std::uint32_t j : o.joints)
      if (j >= joint_count) return bad("occluder '" + m.name + "' maps a joint outside the skin");
    const auto base = static_cast<std::uint32_t>(mesh->positions.size());
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
      glm::u16vec4 joints(0);
      glm::vec4 weights(0.0f);
      bool weighted = false;
      for (int k = 0; k < 4; ++k) {
        if (m.weights[v][k] == 0.0f) continue;
        if (m.joints[v][k] >= k_count)
          return bad("occluder '" + m.name + "' vertex " + std::to_string(v) + " uses a joint its skin lacks");
        joints[k] = static_cast<std::uint16_t>(slot + m.joints[v][k]);
        weights[k] = m.weights[v][k];
        weighted = true;
      }
      if (!weighted) {
        joints = glm::u16vec4(static_cast<std::uint16_t>(slot + k_count), 0, 0, 0);
        weights = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
      }
      mesh->positions.push_back(m.positions[v]);
      mesh->normals.push_back(v < m.normals.size() ? m.normals[v] : glm::vec3(0, 1, 0));
      mesh->joints.push_back(joints);
      mesh->weights.push_back(weights);
    }
    for (std::uint32_t i : m.indices) mesh->indices.push_back(base + i);
    slot += k_count + 1;
  }
  if (!mesh->uvs.empty()) mesh->uvs.resize(mesh->positions.size(), glm::vec2(0.0f));
  auto impl = std::make_unique<Impl>();
  impl->joints = joint_count;
  impl->vertices = n;
  impl->occluders = std::move(occluders);
  impl->context = std::string(context);
  impl->eps_scale = 1e-4f * glm::length(source->bounds.extent());
  impl->mesh = mesh;
  impl->world = std::make_unique<World>();
  World& w = *impl->world;
  impl->entity = w.create();
  w.add<Mesh>(impl->entity, Mesh{mesh});
  w.add<Skin>(impl->entity);
  w.add<SkinPose>(impl->entity, SkinPose{std::vector<glm::mat4>(slot, glm::mat4(1.0f))});
  w.add<WorldTransform>(impl->entity);
  auto scene = RayScene::build(w);
  if (!scene) return bad(scene.error().message);
  impl->scene.emplace(std::move(*scene));
  return PoseAOTracer(std::move(impl));
}

Status PoseAOTracer::trace(std::span<const glm::mat4> joint_matrices, std::uint32_t rays, std::uint64_t seed,
                           JobContext& jobs, std::span<float> ao, std::span<float> standard_error) {
  Impl& s = *impl_;
  const std::size_t n = s.vertices;
  if (joint_matrices.size() != s.joints || ao.size() != n || rays == 0)
    return make_error(ErrorCode::InvalidArgument, s.context + ": trace() needs one matrix per joint and one AO per vertex");
  // Refit the BVH to the pose (the traced mesh's extra joint stays the identity; an occluder's
  // joint follows the traced skin's joint it is).
  SkinPose& pose = s.world->patch<SkinPose>(s.entity);
  std::copy(joint_matrices.begin(), joint_matrices.end(), pose.joint_matrices.begin());
  std::size_t slot = s.joints + 1;
  for (const PoseAOOccluder& o : s.occluders) {
    for (std::size_t k = 0; k < o.joints.size(); ++k)
      pose.joint_matrices[slot + k] = joint_matrices[o.joints[k]] * o.to_traced[k];
    pose.joint_matrices[slot + o.joints.size()] = o.rigid;
    slot += o.joints.size() + 1;
  }
  PENUMBRA_TRY(s.scene->update(*s.world));
  skin_positions(*s.mesh, pose, s.positions);
  skin_normals(*s.mesh, pose, s.normals);
  for (std::size_t v = 0; v < s.positions.size(); ++v)
    if (!std::isfinite(s.positions[v].x + s.positions[v].y + s.positions[v].z))
      return make_error(ErrorCode::InvalidInput,
                        s.context + ": the pose makes " +
                            (v < n ? "vertex " + std::to_string(v) : std::string("an occluder")) + " non-finite");

  const RayScene& scene = *s.scene;
  return jobs.parallel_for(n, 64, [&](std::size_t begin, std::size_t end) {
    std::vector<Ray> batch(rays);
    std::vector<std::uint8_t> blocked(rays);
    for (std::size_t v = begin; v < end; ++v) {
      const glm::vec3 p = s.positions[v], nrm = s.normals[v];
      const float eps = s.eps_scale + 2e-5f * std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
      const Sobol2D scramble(static_cast<std::uint32_t>(mix64(seed ^ kRayStreamTag ^ mix64(v))));
      for (std::uint32_t i = 0; i < rays; ++i) {
        batch[i].origin = p + eps * nrm;
        batch[i].tnear = 0.0f;
        batch[i].direction = to_world(nrm, cosine_hemisphere(scramble(i)));
        batch[i].tfar = std::numeric_limits<float>::infinity();
      }
      scene.occluded(batch, blocked);
      std::uint32_t open = 0;
      for (std::uint32_t i = 0; i < rays; ++i) open += blocked[i] ? 0u : 1u;
      const float a = static_cast<float>(open) / static_cast<float>(rays);
      ao[v] = a;
      if (!standard_error.empty()) standard_error[v] = std::sqrt(a * (1.0f - a) / static_cast<float>(rays));
    }
  });
}

PoseAOOccluder ground_occluder(const MeshData& mesh, std::span<const PoseAOOccluder> others,
                               const glm::mat4& mesh_world) {
  // World up in the bind space the vertices are stored in (the mesh frame: the skinning matrices
  // are the identity in the bind pose), and the character's lowest point and extent along it.
  // A plane's normal maps by the inverse transpose: the local normal of the world's horizontal
  // plane is transpose(M) x +Y.
  glm::vec3 up = glm::transpose(glm::mat3(mesh_world)) * glm::vec3(0.0f, 1.0f, 0.0f);
  up = glm::length(up) > 0.0f && std::isfinite(glm::length(up)) ? glm::normalize(up) : glm::vec3(0.0f, 1.0f, 0.0f);
  float low = std::numeric_limits<float>::max();
  Aabb box;
  const auto take = [&](glm::vec3 q) {
    low = std::min(low, glm::dot(q, up));
    box.extend(q);
  };
  for (const glm::vec3& p : mesh.positions) take(p);
  // An occluder's vertices where the bind pose puts them: skinned by to_traced, or rigid.
  for (const PoseAOOccluder& o : others)
    for (std::size_t v = 0; v < o.mesh->positions.size(); ++v) {
      glm::mat4 m(0.0f);
      float total = 0.0f;
      for (int k = 0; k < 4 && v < o.mesh->weights.size(); ++k) {
        const float w = o.mesh->weights[v][k];
        if (w == 0.0f || o.mesh->joints[v][k] >= o.to_traced.size()) continue;
        m += w * o.to_traced[o.mesh->joints[v][k]];
        total += w;
      }
      take(glm::vec3((total > 0.0f ? m : o.rigid) * glm::vec4(o.mesh->positions[v], 1.0f)));
    }
  const float size = 2.0f * glm::length(box.extent());
  const glm::vec3 centre = box.center() - (glm::dot(box.center(), up) - low) * up;
  const glm::vec3 helper = std::abs(up.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 u = glm::normalize(glm::cross(helper, up)) * size, w = glm::normalize(glm::cross(up, u)) * size;
  auto ground = std::make_shared<MeshData>();
  ground->name = "ground";
  for (const glm::vec3& corner : {centre - u - w, centre + u - w, centre + u + w, centre - u + w}) {
    ground->positions.push_back(corner);
    ground->normals.push_back(up);
    ground->joints.push_back(glm::u16vec4(0));
    ground->weights.push_back(glm::vec4(0.0f));  // weightless: fixed in the traced mesh's frame
  }
  ground->indices = {0, 1, 2, 0, 2, 3};  // facing up
  compute_bounds(*ground);
  PoseAOOccluder o;
  o.mesh = std::move(ground);
  return o;
}

std::vector<PoseAOOccluder> character_occluders(World& world, Entity mesh_entity, std::vector<std::string>* notes) {
  std::vector<PoseAOOccluder> out;
  const Skin* skin = world.alive(mesh_entity) ? world.try_get<Skin>(mesh_entity) : nullptr;
  const WorldTransform* traced_world = world.alive(mesh_entity) ? world.try_get<WorldTransform>(mesh_entity) : nullptr;
  if (skin == nullptr || traced_world == nullptr) return out;
  std::unordered_map<std::uint32_t, std::uint32_t> joint_of;  // entity index -> traced skin joint
  for (std::size_t j = 0; j < skin->joints.size(); ++j)
    joint_of.emplace(skin->joints[j].index, static_cast<std::uint32_t>(j));
  const glm::mat4 to_traced_frame = glm::inverse(traced_world->matrix);
  const auto name_of = [&](Entity e) {
    const Name* n = world.try_get<Name>(e);
    return n ? "'" + n->value + "'" : "entity " + std::to_string(e.index);
  };
  const std::vector<Entity> meshes = character_meshes(world, mesh_entity);
  for (std::size_t m = 1; m < meshes.size(); ++m) {
    const Entity e = meshes[m];
    const Skin& other = world.get<Skin>(e);
    const auto& data = world.get<Mesh>(e).data;
    const WorldTransform* other_world = world.try_get<WorldTransform>(e);
    const auto leave_out = [&](const std::string& why) {
      if (notes) notes->push_back(name_of(e) + " is not traced with " + name_of(mesh_entity) + ": " + why);
    };
    if (!data || other_world == nullptr || data->joints.size() != data->positions.size() ||
        data->weights.size() != data->positions.size() || other.inverse_bind.size() != other.joints.size()) {
      leave_out("its skinning (JOINTS_0/WEIGHTS_0, inverse bind matrices) is incomplete");
      continue;
    }
    PoseAOOccluder o;
    o.mesh = data;
    std::string missing;
    bool in_range = true;
    std::vector<std::uint8_t> used(other.joints.size(), 0);
    for (std::size_t v = 0; v < data->positions.size(); ++v)
      for (int k = 0; k < 4; ++k)
        if (data->weights[v][k] != 0.0f) {
          if (data->joints[v][k] < used.size()) used[data->joints[v][k]] = 1;
          else in_range = false;
        }
    if (!in_range) {
      leave_out("a vertex uses a joint index its skin does not have");
      continue;
    }
    for (std::size_t k = 0; k < other.joints.size(); ++k) {
      const auto it = joint_of.find(other.joints[k].index);
      const bool same = it != joint_of.end() && skin->joints[it->second] == other.joints[k];
      if (!same && used[k] && missing.empty()) missing = name_of(other.joints[k]);
      const std::uint32_t j = same ? it->second : 0;
      o.joints.push_back(j);
      // Step 3 (the character's meshes traced together): the occluder's bind vertex in the traced
      // skin's bind frame of joint j, which M_j then poses.
      o.to_traced.push_back(same ? glm::inverse(skin->inverse_bind[j]) * other.inverse_bind[k] : glm::mat4(1.0f));
    }
    if (!missing.empty()) {
      leave_out("its skin moves joint " + missing + ", which " + name_of(mesh_entity) + "'s skin lacks");
      continue;
    }
    o.rigid = to_traced_frame * other_world->matrix;
    if (!finite_matrix(o.rigid)) continue;
    out.push_back(std::move(o));
  }
  return out;
}

Status PoseAOTraining::add_pose(PoseAOTracer& tracer, const PoseRig& rig, const Pose& pose, std::uint32_t rays,
                                std::uint64_t seed, JobContext& jobs) {
  const std::vector<glm::mat4> matrices = skinning_matrices(rig, pose);
  std::vector<float> f;
  pose_features(rig.parents, matrices, f);
  std::vector<float> a(vertex_count);
  PENUMBRA_TRY(tracer.trace(matrices, rays, seed, jobs, a));
  features.insert(features.end(), f.begin(), f.end());
  ao.insert(ao.end(), a.begin(), a.end());
  return {};
}

// ---------------------------------------------------------------------------------------------
// Step 4: the per-vertex fit.

namespace {

using JointSet = std::array<std::uint16_t, kPoseAOMaxLocality + 1>;  // joints ascending, then the count

constexpr int kCensoredPasses = 4;  // refits of the clamped model (fit_pose_ao)
// Clusters (pose_ao.h): one per kPosesPerClusterCoefficient x coefficients training poses at most;
// Lloyd iterations of k-means at most; the fraction of the training poses that blend clusters
// (the blend band is set to give it: the per-frame cost grows with it); the least relative cut in
// the validation error that justifies more clusters.
constexpr std::size_t kPosesPerClusterCoefficient = 3;
constexpr int kLloydIterations = 20;
constexpr double kBlendedPoses = 0.1;
constexpr double kClusterGain = 0.01;
// Bind blend candidates (PoseAOGroup), as fractions of the median squared pose distance.
constexpr double kBindBlendFractions[] = {1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3};

// The design of a joint set over the first `poses` poses: row p is theta_local = [1, f_j1 .. f_jk]
// (pose_ao.h) of pose p, poses x (1 + 9 k) row-major.
std::vector<double> set_design(const PoseAOTraining& training, std::span<const std::uint16_t> joints,
                               std::size_t poses) {
  const std::size_t F = training.joint_count * kPoseFeaturesPerJoint, C = 1 + joints.size() * kPoseFeaturesPerJoint;
  std::vector<double> design(poses * C);
  for (std::size_t p = 0; p < poses; ++p) {
    design[p * C] = 1.0;
    for (std::size_t i = 0; i < joints.size(); ++i)
      for (std::size_t e = 0; e < kPoseFeaturesPerJoint; ++e)
        design[p * C + 1 + i * kPoseFeaturesPerJoint + e] =
            static_cast<double>(training.features[p * F + std::size_t{joints[i]} * kPoseFeaturesPerJoint + e]);
  }
  return design;
}

// Locality (algorithms.md P5): per vertex at most k joints. Candidates are the joints whose
// rotation can move geometry against the vertex: joint j's rotation moves its subtree against the
// rest of the character, so j qualifies when there is geometry on the other side of it (roots
// never do) and it moves in the reference poses. Among them the vertex takes its skinning joints
// (by weight) and then the joints whose parameters alone explain most of its AO over the
// reference poses (a 10-coefficient ridge fit per joint, one factorisation per joint), which
// finds the joints whose bones come near the vertex in the poses that were traced. Vertices of
// rare joint sets then join the large set that serves them best (see below).
std::vector<JointSet> select_joints(const MeshData& mesh, const PoseRig& rig, const std::vector<bool>& moving,
                                    std::uint32_t k, const PoseAOTraining& training, std::size_t poses, double lambda) {
  const std::size_t n = mesh.positions.size(), joints = rig.joint_count();
  // One single-joint design [1, f_j] and factorisation per moving joint.
  std::vector<std::optional<pose_ao_detail::RidgeSolver>> alone(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    const auto joint = static_cast<std::uint16_t>(j);
    if (moving[j]) alone[j].emplace(set_design(training, {&joint, 1}, poses), poses, pose_ao_coefficients(1), lambda);
  }
  const auto dominant = [&](std::size_t v) {
    std::size_t best = joints;
    float w = 0.0f;
    for (int c = 0; c < 4; ++c)
      if (mesh.weights[v][c] > w && mesh.joints[v][c] < joints) { w = mesh.weights[v][c]; best = mesh.joints[v][c]; }
    return best;
  };
  // in_subtree[j * (joints + 1) + i]: joint i lies in joint j's subtree (index `joints`: no joint).
  std::vector<std::uint8_t> in_subtree(joints * (joints + 1), 0);
  for (std::size_t i = 0; i < joints; ++i)
    for (std::int32_t a = static_cast<std::int32_t>(i); a >= 0; a = rig.parents[static_cast<std::size_t>(a)])
      in_subtree[static_cast<std::size_t>(a) * (joints + 1) + i] = 1;
  const std::size_t stride = std::max<std::size_t>(1, n / 2048);
  std::vector<std::size_t> sample_joint;
  std::vector<glm::vec3> sample_pos;
  for (std::size_t u = 0; u < n; u += stride) {
    sample_joint.push_back(dominant(u));
    sample_pos.push_back(mesh.positions[u]);
  }
  // Per vertex and candidate joint: its skinning weight and the AO its parameters explain alone
  // (-1 for a joint that is no candidate).
  std::vector<float> weight_of(n * joints, 0.0f);
  std::vector<double> explained_of(n * joints, -1.0);
  std::vector<float> nearest(joints + 1);
  for (std::size_t v = 0; v < n; ++v) {
    std::fill(nearest.begin(), nearest.end(), std::numeric_limits<float>::infinity());
    for (std::size_t u = 0; u < sample_pos.size(); ++u) {
      const glm::vec3 d = sample_pos[u] - mesh.positions[v];
      nearest[sample_joint[u]] = std::min(nearest[sample_joint[u]], glm::dot(d, d));
    }
    const std::size_t own = dominant(v);
    for (std::size_t j = 0; j < joints; ++j) {
      if (!moving[j]) continue;
      const bool inside = in_subtree[j * (joints + 1) + own] != 0;
      float d = std::numeric_limits<float>::infinity();
      for (std::size_t i = 0; i <= joints; ++i)
        if ((in_subtree[j * (joints + 1) + i] != 0) != inside) d = std::min(d, nearest[i]);
      if (!std::isfinite(d)) continue;
      for (int c = 0; c < 4; ++c)
        if (mesh.joints[v][c] == j) weight_of[v * joints + j] += mesh.weights[v][c];
      explained_of[v * joints + j] = alone[j]->explained(training.ao.data() + v, n);
    }
  }
  // How well a joint set serves vertex v: skinning weight covered first, then AO explained.
  const auto value = [&](std::size_t v, const JointSet& set) {
    std::pair<float, double> sum{0.0f, 0.0};
    for (std::size_t i = 0; i < set[kPoseAOMaxLocality]; ++i) {
      sum.first += weight_of[v * joints + set[i]];
      sum.second += std::max(0.0, explained_of[v * joints + set[i]]);
    }
    return sum;
  };

  // Each vertex's own best set: skinning joints (heavier first), then by explained AO.
  std::vector<JointSet> sets(n);
  std::vector<std::pair<std::pair<float, double>, std::size_t>> ranked;
  for (std::size_t v = 0; v < n; ++v) {
    ranked.clear();
    for (std::size_t j = 0; j < joints; ++j)
      if (explained_of[v * joints + j] >= 0.0)
        ranked.push_back({{-weight_of[v * joints + j], -explained_of[v * joints + j]}, j});
    std::sort(ranked.begin(), ranked.end());
    JointSet set{};
    const std::size_t count = std::min<std::size_t>(k, ranked.size());
    for (std::size_t i = 0; i < count; ++i) set[i] = static_cast<std::uint16_t>(ranked[i].second);
    for (std::size_t i = 1; i < count; ++i)  // ascending (insertion sort of at most 4)
      for (std::size_t m = i; m > 0 && set[m - 1] > set[m]; --m) std::swap(set[m - 1], set[m]);
    set[kPoseAOMaxLocality] = static_cast<std::uint16_t>(count);
    sets[v] = set;
  }

  // Few large groups run fast (blocks of kPoseAOBlock vertices at runtime), so a vertex whose set
  // has fewer than kMinGroup vertices moves to another: the one whose linear fit explains most of
  // its AO over the reference poses, among the set pooled for its dominant joint (the k joints of
  // most skinning weight, then most explained AO, summed over that joint's vertices of rare sets)
  // and the kMergeCandidates large sets that cover most of its skinning weight and that explain
  // most alone. Where the vertices' own sets scatter (fingers, whose neighbours each explain a
  // little), the pooled set keeps their own joints, which no large set holds.
  constexpr std::size_t kMinGroup = 16, kMergeCandidates = 8;
  std::map<JointSet, std::size_t> sizes;
  for (const JointSet& set : sets) ++sizes[set];
  std::vector<JointSet> large;
  for (const auto& [set, size] : sizes)
    if (size >= kMinGroup) large.push_back(set);
  // A set's design [1, f_j1 .. f_jk] over the poses and its factorisation, made when first needed.
  std::map<JointSet, pose_ao_detail::RidgeSolver> solvers;
  const auto solver_of = [&](const JointSet& set) -> const pose_ao_detail::RidgeSolver& {
    if (const auto it = solvers.find(set); it != solvers.end()) return it->second;
    const std::size_t count = set[kPoseAOMaxLocality];
    return solvers
        .try_emplace(set, set_design(training, std::span(set).first(count), poses), poses,
                     pose_ao_coefficients(static_cast<std::uint32_t>(count)), lambda)
        .first->second;
  };
  std::map<std::size_t, std::vector<std::size_t>> rare;  // by dominant joint
  for (std::size_t v = 0; v < n; ++v)
    if (sizes[sets[v]] < kMinGroup) rare[dominant(v)].push_back(v);
  std::vector<std::pair<float, double>> score(joints);
  std::vector<std::size_t> by_value(large.size()), by_explained(large.size());
  for (const auto& [own, vertices] : rare) {
    std::fill(score.begin(), score.end(), std::pair<float, double>{0.0f, 0.0});
    std::vector<bool> candidate(joints, false);
    for (const std::size_t v : vertices)
      for (std::size_t j = 0; j < joints; ++j) {
        if (explained_of[v * joints + j] < 0.0) continue;
        candidate[j] = true;
        score[j].first += weight_of[v * joints + j];
        score[j].second += explained_of[v * joints + j];
      }
    ranked.clear();
    for (std::size_t j = 0; j < joints; ++j)
      if (candidate[j]) ranked.push_back({{-score[j].first, -score[j].second}, j});
    std::sort(ranked.begin(), ranked.end());
    JointSet pooled{};
    const std::size_t count = std::min<std::size_t>(k, ranked.size());
    for (std::size_t i = 0; i < count; ++i) pooled[i] = static_cast<std::uint16_t>(ranked[i].second);
    std::sort(pooled.begin(), pooled.begin() + static_cast<std::ptrdiff_t>(count));
    pooled[kPoseAOMaxLocality] = static_cast<std::uint16_t>(count);
    for (const std::size_t v : vertices) {
      std::iota(by_value.begin(), by_value.end(), std::size_t{0});
      std::iota(by_explained.begin(), by_explained.end(), std::size_t{0});
      const std::size_t m = std::min(kMergeCandidates, large.size());
      const auto first = [&](std::vector<std::size_t>& order, auto key) {
        std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(m), order.end(),
                          [&](std::size_t a, std::size_t b) { return key(a) > key(b) || (key(a) == key(b) && a < b); });
      };
      first(by_value, [&](std::size_t i) { return value(v, large[i]); });
      first(by_explained, [&](std::size_t i) { return value(v, large[i]).second; });
      const JointSet* best = &pooled;
      double most = solver_of(pooled).explained(training.ao.data() + v, n);
      for (const auto* order : {&by_value, &by_explained})
        for (std::size_t c = 0; c < m; ++c) {
          const JointSet& set = large[(*order)[c]];
          if (const double e = solver_of(set).explained(training.ao.data() + v, n); e > most) {
            most = e;
            best = &set;
          }
        }
      sets[v] = *best;
    }
  }
  return sets;
}

// Step 4b (clusters, after Kirk & Arikan 2007): k-means over the poses' theta_local (without the
// leading 1; `x` is P x dims), seeded by k-means++ with a generator fixed per joint set, then Lloyd
// iterations (sums in pose order: deterministic). A centre that loses all its poses keeps its
// place. Writes clusters x dims centres; returns the blend band (pose_ao_cluster_weights).
float cluster_poses(const std::vector<float>& x, std::size_t P, std::size_t dims, std::uint32_t clusters,
                    std::uint64_t seed, float* centers) {
  const auto distance = [&](const float* a, const float* b) {
    double d = 0.0;
    for (std::size_t i = 0; i < dims; ++i) d += double(a[i] - b[i]) * double(a[i] - b[i]);
    return d;
  };
  // k-means++: each next centre drawn with probability proportional to the squared distance to the
  // nearest chosen one.
  Rng rng = Rng::stream(seed, clusters);
  std::vector<double> nearest(P, std::numeric_limits<double>::infinity());
  std::copy_n(x.data() + (rng.next_u32() % P) * dims, dims, centers);
  for (std::uint32_t m = 1; m < clusters; ++m) {
    double total = 0.0;
    for (std::size_t p = 0; p < P; ++p) {
      nearest[p] = std::min(nearest[p], distance(x.data() + p * dims, centers + (m - 1) * dims));
      total += nearest[p];
    }
    double r = rng.next_double() * total;
    std::size_t pick = 0;
    for (; pick + 1 < P; ++pick) {
      r -= nearest[pick];
      if (r < 0.0) break;
    }
    std::copy_n(x.data() + pick * dims, dims, centers + m * dims);
  }
  // Lloyd iterations.
  std::vector<std::uint32_t> owner(P, 0);
  std::vector<double> sum(clusters * dims);
  std::vector<std::size_t> count(clusters);
  for (int iteration = 0; iteration < kLloydIterations; ++iteration) {
    bool moved = false;
    for (std::size_t p = 0; p < P; ++p) {
      std::uint32_t best = 0;
      double least = std::numeric_limits<double>::infinity();
      for (std::uint32_t m = 0; m < clusters; ++m)
        if (const double d = distance(x.data() + p * dims, centers + m * dims); d < least) {
          least = d;
          best = m;
        }
      moved |= iteration == 0 || owner[p] != best;
      owner[p] = best;
    }
    if (!moved) break;
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(count.begin(), count.end(), 0);
    for (std::size_t p = 0; p < P; ++p) {
      ++count[owner[p]];
      for (std::size_t i = 0; i < dims; ++i) sum[owner[p] * dims + i] += x[p * dims + i];
    }
    for (std::uint32_t m = 0; m < clusters; ++m)
      if (count[m] > 0)
        for (std::size_t i = 0; i < dims; ++i) centers[m * dims + i] = float(sum[m * dims + i] / double(count[m]));
  }
  // The band: the gap between the nearest and the second nearest centre (squared distances) that
  // kBlendedPoses of the poses fall within.
  std::vector<double> gaps(P);
  for (std::size_t p = 0; p < P; ++p) {
    double first = std::numeric_limits<double>::infinity(), second = first;
    for (std::uint32_t m = 0; m < clusters; ++m) {
      const double d = distance(x.data() + p * dims, centers + m * dims);
      if (d < first) {
        second = first;
        first = d;
      } else if (d < second) {
        second = d;
      }
    }
    gaps[p] = second - first;
  }
  const auto at = static_cast<std::ptrdiff_t>(kBlendedPoses * static_cast<double>(P - 1));
  std::nth_element(gaps.begin(), gaps.begin() + at, gaps.end());
  return static_cast<float>(gaps[static_cast<std::size_t>(at)]);
}

}  // namespace

Result<PoseAOData> fit_pose_ao(const PoseAOTraining& training, const PoseRig& rig, const MeshData& mesh,
                               const SkinnedPoseAO& settings, std::size_t poses, JobContext& jobs,
                               std::vector<std::string>* warnings, std::string_view context) {
  const std::size_t available = training.poses();
  const std::size_t P = poses == 0 ? available : std::min(poses, available);
  const std::size_t V = training.vertex_count, J = training.joint_count, F = J * kPoseFeaturesPerJoint;
  if (P == 0 || V != mesh.positions.size() || J != rig.joint_count() || training.bind_ao.size() != V)
    return make_error(ErrorCode::InvalidArgument, std::string(context) + ": no reference pose to fit (or the training "
                                                                         "data does not match the mesh); bake poses first");

  // Joints whose parameters change over the poses used (by more than float rounding of the
  // products: 1e-5 is a rotation of 1e-5 rad).
  std::vector<bool> moving(J, false);
  for (std::size_t p = 1; p < P; ++p)
    for (std::size_t i = 0; i < F; ++i)
      if (std::abs(training.features[p * F + i] - training.features[i]) > 1e-5f) moving[i / kPoseFeaturesPerJoint] = true;

  // Fewer poses than coefficients: reduce the locality until 1 + 9 k <= P.
  std::uint32_t k = std::min(settings.locality, kPoseAOMaxLocality);
  const auto fits = static_cast<std::uint32_t>(std::min<std::size_t>((P - 1) / kPoseFeaturesPerJoint, kPoseAOMaxLocality));
  if (fits < k) {
    const std::string message = std::string(context) + ": " + std::to_string(P) + " reference poses for " +
                                std::to_string(pose_ao_coefficients(k)) + " coefficients per vertex; locality reduced from " +
                                std::to_string(k) + " to " + std::to_string(fits) + " joints (bake at least " +
                                std::to_string(pose_ao_coefficients(k)) + " poses, several times more for a good fit)";
    log(LogLevel::Warning, message);
    if (warnings) warnings->push_back(message);
    k = fits;
  }

  // Group the vertices by joint set (std::map: a deterministic order).
  const std::vector<JointSet> sets = select_joints(mesh, rig, moving, k, training, P, static_cast<double>(settings.lambda));
  std::map<JointSet, std::vector<std::uint32_t>> by_set;
  for (std::size_t v = 0; v < V; ++v) by_set[sets[v]].push_back(static_cast<std::uint32_t>(v));

  PoseAOData data;
  data.vertex_count = static_cast<std::uint32_t>(V);
  data.joint_count = static_cast<std::uint32_t>(J);
  data.joint_parents = rig.parents;
  data.poses = static_cast<std::uint32_t>(P);
  data.rays_per_vertex = settings.rays_per_vertex;
  data.requested_locality = settings.locality;
  data.locality = k;
  data.requested_clusters = settings.clusters;
  std::vector<const std::vector<std::uint32_t>*> members;
  for (const auto& [set, vertices] : by_set) {
    PoseAOGroup g;
    g.joint_count = set[kPoseAOMaxLocality];
    for (std::uint32_t i = 0; i < g.joint_count; ++i) g.joints[i] = set[i];
    g.first = static_cast<std::uint32_t>(data.vertex_order.size());
    g.count = static_cast<std::uint32_t>(vertices.size());
    data.vertex_order.insert(data.vertex_order.end(), vertices.begin(), vertices.end());
    data.groups.push_back(g);
    members.push_back(&vertices);
  }
  // Clusters: as many as asked while each has kPosesPerClusterCoefficient poses per coefficient.
  const std::uint32_t affordable = static_cast<std::uint32_t>(
      std::min<std::size_t>(P / (kPosesPerClusterCoefficient * pose_ao_coefficients(k)), kPoseAOMaxClusters));
  const std::uint32_t max_clusters = k == 0 ? 1u : std::clamp(std::min(settings.clusters, affordable), 1u, kPoseAOMaxClusters);
  // (Not repeated when the locality was already reduced for want of poses.)
  if (max_clusters < std::min(settings.clusters, kPoseAOMaxClusters) && k > 0 &&
      k == std::min(settings.locality, kPoseAOMaxLocality)) {
    const std::string message =
        std::string(context) + ": " + std::to_string(P) + " reference poses allow " + std::to_string(max_clusters) +
        " of the " + std::to_string(settings.clusters) + " clusters asked for (each needs " +
        std::to_string(kPosesPerClusterCoefficient * pose_ao_coefficients(k)) + " poses); bake more poses for more";
    log(LogLevel::Info, message);
    if (warnings) warnings->push_back(message);
  }

  // Per joint set: the cluster count by validation, then the final fit of every vertex. Results
  // per set, assembled in set order below.
  struct GroupResult {
    std::vector<float> centers;
    std::vector<std::uint16_t> coefficients;  // the group's halves, laid out as PoseAOGroup says
  };
  std::vector<GroupResult> results(data.groups.size());
  std::vector<double> group_error(data.groups.size(), 0.0);
  // The cluster counts tried (1, 2, 4, .. up to max_clusters) and the ridge strengths (lambda,
  // lambda / 10, lambda / 100; 0 tries 0 alone).
  std::vector<std::uint32_t> counts;
  for (std::uint32_t c = 1; c <= max_clusters; c = c < max_clusters ? std::min(2 * c, max_clusters) : c + 1)
    counts.push_back(c);
  const double lambda = static_cast<double>(settings.lambda);
  const std::vector<double> strengths =
      lambda > 0.0 ? std::vector<double>{lambda, 0.1 * lambda, 0.01 * lambda} : std::vector<double>{0.0};
  // Per joint set, the validation error of each (count, strength), counts outer.
  std::vector<std::vector<double>> validation(data.groups.size());
  // The cluster count of a set under a strength: each count must cut the least error so far by
  // kClusterGain.
  const auto chosen_count = [&](std::size_t gi, std::size_t strength) {
    std::size_t chosen = 0;
    double least = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < counts.size() && !validation[gi].empty(); ++c)
      if (const double e = validation[gi][c * strengths.size() + strength]; e < (1.0 - kClusterGain) * least) {
        least = e;
        chosen = c;
      }
    return chosen;
  };
  std::size_t strength = 0;  // chosen between the passes
  // Two passes over the joint sets: the validation errors, then (with one strength for the whole
  // character, see step 4c) the final fits.
  for (const bool choosing : {true, false}) {
    jobs.begin_stage(choosing ? "pose-ao fit: validation" : "pose-ao fit", data.groups.size());
    PENUMBRA_TRY(jobs.parallel_for(data.groups.size(), 1, [&](std::size_t begin, std::size_t end) {
      for (std::size_t gi = begin; gi < end; ++gi) {
        PoseAOGroup& g = data.groups[gi];
        const std::vector<std::uint32_t>& vertices = *members[gi];
        const std::size_t C = g.coefficient_count();
        const std::vector<double> theta = set_design(training, std::span(g.joints).first(g.joint_count), P);
        std::vector<float> x(P * (C - 1));  // theta_local without the 1, for the clusters
        for (std::size_t p = 0; p < P; ++p)
          for (std::size_t e = 1; e < C; ++e) x[p * (C - 1) + e - 1] = static_cast<float>(theta[p * C + e]);
        std::uint64_t seed = 0;
        for (std::uint32_t j = 0; j < g.joint_count; ++j) seed = seed * 65537u + g.joints[j] + 1u;

        // A model of `clusters` clusters fitted to the poses `rows`: the clusters, then the design
        // of the blended local models (pose_ao.h): row p holds w_m(pose p) theta_p in cluster m's
        // columns, fitted jointly, each cluster's ridge scaled by its weight in the poses. One
        // cluster: the thesis' linear model, its bias free.
        struct Model {
          std::uint32_t clusters = 1;
          float band = 0.0f;
          std::vector<float> centers;  // the metric's scales, then the centres (PoseAOGroup)
          std::optional<pose_ao_detail::RidgeSolver> solver;
          // theta_local without the 1 of pose p, in the clusters' metric.
          void scaled(const float* x, std::size_t dims, float* out) const {
            for (std::size_t e = 0; e < dims; ++e) out[e] = x[e] * centers[e];
          }
        };
        // The clusters' metric (PoseAOGroup): each parameter's scale, the RMS over the set's
        // vertices of its coefficient in the set's linear model on the poses `rows`. Once per rows
        // and strength (every cluster count tried shares it).
        std::vector<std::tuple<const std::vector<std::size_t>*, double, std::vector<float>>> metrics;
        const auto metric = [&](const std::vector<std::size_t>& rows, double ridge_strength) -> const std::vector<float>& {
          for (const auto& [made_for, made_with, scales] : metrics)
            if (made_for == &rows && made_with == ridge_strength) return scales;
          const std::size_t R = rows.size();
          std::vector<double> linear(R * C);
          for (std::size_t r = 0; r < R; ++r) std::copy_n(theta.data() + rows[r] * C, C, linear.data() + r * C);
          const pose_ao_detail::RidgeSolver solver(linear, R, C, ridge_strength);
          std::vector<float> y(R);
          std::vector<double> t(C), sum(C, 0.0);
          for (const std::uint32_t v : vertices) {
            for (std::size_t r = 0; r < R; ++r) y[r] = training.ao[rows[r] * V + v];
            solver.solve(y.data(), 1, t);
            for (std::size_t e = 1; e < C; ++e) sum[e] += t[e] * t[e];
          }
          std::vector<float> scales(C - 1);
          for (std::size_t e = 1; e < C; ++e)
            scales[e - 1] = static_cast<float>(std::sqrt(sum[e] / static_cast<double>(vertices.size())));
          return std::get<2>(metrics.emplace_back(&rows, ridge_strength, std::move(scales)));
        };
        const auto make_model = [&](const std::vector<std::size_t>& rows, std::uint32_t clusters, double ridge_strength,
                                    Model& m) {
          const std::size_t R = rows.size(), U = std::size_t{clusters} * C;
          m.clusters = clusters;
          std::vector<double> weights(R * clusters, clusters == 1 ? 1.0 : 0.0);  // per row, per cluster
          if (clusters > 1) {
            m.centers = metric(rows, ridge_strength);
            m.centers.resize(std::size_t{clusters + 1} * (C - 1));
            std::vector<float> xs(R * (C - 1));
            for (std::size_t r = 0; r < R; ++r) m.scaled(x.data() + rows[r] * (C - 1), C - 1, xs.data() + r * (C - 1));
            float* centers = m.centers.data() + (C - 1);
            m.band = cluster_poses(xs, R, C - 1, clusters, seed, centers);
            float w[kPoseAOMaxClusters];
            for (std::size_t r = 0; r < R; ++r) {
              pose_ao_cluster_weights(centers, clusters, static_cast<std::uint32_t>(C - 1),
                                      xs.data() + r * (C - 1), m.band, w);
              for (std::uint32_t c = 0; c < clusters; ++c) weights[r * clusters + c] = static_cast<double>(w[c]);
            }
          }
          std::vector<double> design(R * U, 0.0), mass(clusters, 0.0);
          for (std::size_t r = 0; r < R; ++r)
            for (std::uint32_t c = 0; c < clusters; ++c) {
              const double w = weights[r * clusters + c];
              mass[c] += w;
              if (w != 0.0)
                for (std::size_t e = 0; e < C; ++e) design[r * U + c * C + e] = w * theta[rows[r] * C + e];
            }
          std::vector<double> ridge(U);
          for (std::uint32_t c = 0; c < clusters; ++c)
            for (std::size_t e = 0; e < C; ++e)  // the bias: none alone, a hundredth among clusters
              ridge[c * C + e] = ridge_strength * mass[c] * (e > 0 ? 1.0 : clusters > 1 ? 0.01 : 0.0);
          m.solver.emplace(design, R, U, ridge);
        };
        // Vertex v's coefficients t under model m over `rows`. The model is clamped to [0, 1] where it
        // is evaluated, so a pose whose AO is at a bound (a vertex fully open) is fitted by any
        // prediction beyond that bound: refit with such targets moved to the prediction (censored
        // regression, a few fixed-point steps).
        std::vector<float> target(P);
        const auto fit_vertex = [&](const Model& m, const std::vector<std::size_t>& rows, std::uint32_t v,
                                    std::vector<double>& t) {
          t.assign(std::size_t{m.clusters} * C, 0.0);
          for (std::size_t r = 0; r < rows.size(); ++r) target[r] = training.ao[rows[r] * V + v];
          m.solver->solve(target.data(), 1, t);
          for (int pass = 0; pass < kCensoredPasses; ++pass) {
            bool changed = false;
            for (std::size_t r = 0; r < rows.size(); ++r) {
              const double a = m.solver->predict(r, t);
              const float y = training.ao[rows[r] * V + v];
              float y2 = y;
              if (y >= 1.0f && a > 1.0) y2 = static_cast<float>(a);
              if (y <= 0.0f && a < 0.0) y2 = static_cast<float>(a);
              changed |= y2 != target[r];
              target[r] = y2;
            }
            if (!changed) break;
            m.solver->solve(target.data(), 1, t);
          }
        };

        // Step 4c: the cluster count and the ridge strength by the error on every fifth pose when fitted
        // to the others (more clusters and a weaker ridge fit the training poses better, and overfit
        // where the poses do not support them). The strength is chosen for the whole character, the
        // one whose counts give the least error summed over the sets (per set, a choice among more
        // models picks up the noise of the 64-ray references), then each set's count under it.
        if (choosing) {
          if (g.joint_count == 0) continue;
          std::vector<std::size_t> fit_rows, check_rows;
          for (std::size_t p = 0; p < P; ++p) (p % 5 == 4 ? check_rows : fit_rows).push_back(p);
          std::vector<double> t;
          std::vector<float> xp(C - 1);
          float w[kPoseAOMaxClusters];
          for (const std::uint32_t candidate : counts)
            for (const double ridge : strengths) {
              Model m;
              make_model(fit_rows, candidate, ridge, m);
              double error = 0.0;
              for (std::uint32_t v : vertices) {
                fit_vertex(m, fit_rows, v, t);
                for (std::size_t p : check_rows) {
                  if (candidate > 1) {
                    m.scaled(x.data() + p * (C - 1), C - 1, xp.data());
                    pose_ao_cluster_weights(m.centers.data() + (C - 1), candidate, static_cast<std::uint32_t>(C - 1),
                                            xp.data(), m.band, w);
                  }
                  double a = 0.0;
                  for (std::uint32_t c = 0; c < candidate; ++c) {
                    const double wc = candidate > 1 ? static_cast<double>(w[c]) : 1.0;
                    if (wc == 0.0) continue;
                    double dot = 0.0;
                    for (std::size_t e = 0; e < C; ++e) dot += t[c * C + e] * theta[p * C + e];
                    a += wc * dot;
                  }
                  const double d = std::clamp(a, 0.0, 1.0) - static_cast<double>(training.ao[p * V + v]);
                  error += d * d;
                }
              }
              validation[gi].push_back(error);
            }
          continue;
        }
        const std::uint32_t clusters = g.joint_count == 0 ? 1u : counts[chosen_count(gi, strength)];

        // The final fit on every pose.
        std::vector<std::size_t> all(P);
        for (std::size_t p = 0; p < P; ++p) all[p] = p;
        Model model;
        make_model(all, clusters, strengths[strength], model);
        g.cluster_count = clusters;
        g.cluster_band = model.band;
        const std::size_t U = std::size_t{clusters} * C;
        GroupResult& result = results[gi];
        result.centers = std::move(model.centers);
        result.coefficients.assign(g.coefficient_span(), 0);
        // Bind blend candidates (PoseAOGroup): none, then fractions of the median distance of the
        // poses from the bind pose; each pose's weight per candidate.
        std::vector<double> d2(P, 0.0);
        for (std::size_t p = 0; p < P; ++p)
          for (std::size_t c = 1; c < C; ++c) d2[p] += theta[p * C + c] * theta[p * C + c];
        std::vector<double> sorted_d2 = d2;
        std::nth_element(sorted_d2.begin(), sorted_d2.begin() + static_cast<std::ptrdiff_t>(P / 2), sorted_d2.end());
        const double median_d2 = sorted_d2[P / 2];
        std::vector<double> blends = {0.0};
        if (g.joint_count > 0 && median_d2 > 0.0)
          for (double fraction : kBindBlendFractions) blends.push_back(fraction * median_d2);
        std::vector<double> weight(blends.size() * P), blend_error(blends.size(), 0.0);
        for (std::size_t b = 0; b < blends.size(); ++b)
          for (std::size_t p = 0; p < P; ++p)
            weight[b * P + p] = blends[b] == 0.0 ? 1.0 : std::min(1.0, d2[p] / blends[b]);
        std::vector<double> t;
        for (std::uint32_t i = 0; i < g.count; ++i) {
          const std::uint32_t v = vertices[i];
          fit_vertex(model, all, v, t);
          // As halves (the ridge keeps them far inside the half range; saturated in case it does not).
          for (std::size_t u = 0; u < U; ++u) {
            const auto m = static_cast<std::uint32_t>(u / C), c = static_cast<std::uint32_t>(u % C);
            result.coefficients[g.coefficient_index(m, c, i) - g.coefficient_offset] =
                glm::packHalf1x16(static_cast<float>(std::clamp(t[u], -65504.0, 65504.0)));
          }
          const double bind = static_cast<double>(training.bind_ao[v]);
          for (std::size_t p = 0; p < P; ++p) {
            const double a = std::clamp(model.solver->predict(p, t), 0.0, 1.0);
            const double y = static_cast<double>(training.ao[p * V + v]);
            for (std::size_t b = 0; b < blends.size(); ++b) {
              const double err = bind + weight[b * P + p] * (a - bind) - y;
              blend_error[b] += err * err;
            }
          }
        }
        // The blend with the least training error (the smallest on ties).
        std::size_t best = 0;
        for (std::size_t b = 1; b < blends.size(); ++b)
          if (blend_error[b] < blend_error[best]) best = b;
        g.bind_blend = static_cast<float>(blends[best]);
        group_error[gi] = blend_error[best];
      }
    }));
    if (choosing) {
      // The strength of least summed validation error (the strongest on ties).
      double least = std::numeric_limits<double>::infinity();
      for (std::size_t s = 0; s < strengths.size(); ++s) {
        double sum = 0.0;
        for (std::size_t gi = 0; gi < data.groups.size(); ++gi)
          if (!validation[gi].empty()) sum += validation[gi][chosen_count(gi, s) * strengths.size() + s];
        if (sum < least) {
          least = sum;
          strength = s;
        }
      }
    }
  }
  // Assemble the sets' coefficients and centres in set order.
  data.lambda = static_cast<float>(strengths[strength]);
  data.clusters = 1;
  for (std::size_t gi = 0; gi < data.groups.size(); ++gi) {
    PoseAOGroup& g = data.groups[gi];
    g.coefficient_offset = data.coefficients.size();
    g.center_offset = g.cluster_count > 1 ? data.centers.size() : 0;
    data.coefficients.insert(data.coefficients.end(), results[gi].coefficients.begin(), results[gi].coefficients.end());
    data.centers.insert(data.centers.end(), results[gi].centers.begin(), results[gi].centers.end());
    data.clusters = std::max(data.clusters, g.cluster_count);
  }
  double sum = 0.0;
  for (double e : group_error) sum += e;
  data.training_rmse = static_cast<float>(std::sqrt(sum / static_cast<double>(P * V)));

  // Baselines: the bind pose, and the mean over the reference poses (summed in pose order).
  data.bind_ao = training.bind_ao;
  data.mean_ao.assign(V, 0.0f);
  for (std::size_t v = 0; v < V; ++v) {
    double m = 0.0;
    for (std::size_t p = 0; p < P; ++p) m += static_cast<double>(training.ao[p * V + v]);
    data.mean_ao[v] = static_cast<float>(m / static_cast<double>(P));
  }
  return data;
}

namespace {

// One character as a group of poses: element 0 the bind pose, then the reference poses (random,
// then from the clips). Pose p's results: its features (J x 9 floats; zero for the bind pose) and
// every vertex's AO (V floats). prepare() checks the rig and picks the pose space, run() traces
// poses, finish_pose_ao() fits from the results alone (the step that needs every pose).
class PoseBake {
 public:
  static Result<std::shared_ptr<PoseBake>> prepare(World& world, Entity e, const SkinnedPoseAO& settings,
                                                   std::uint64_t seed, MemoryBudget& budget,
                                                   std::vector<std::string>* warnings);
  std::uint64_t elements() const { return 1 + poses_; }
  double element_cost() const { return double(vertices_) * settings_.rays_per_vertex; }
  std::vector<std::byte> header() const;
  Result<std::vector<std::byte>> run(std::uint64_t begin, std::uint64_t end, JobContext& jobs);

 private:
  std::string context_;
  SkinnedPoseAO settings_;
  std::shared_ptr<const MeshData> mesh_;
  PoseRig rig_;
  PoseSpace space_;
  std::optional<PoseAOTracer> tracer_;
  std::uint64_t seed_ = 0;
  std::size_t vertices_ = 0, poses_ = 0;
};

Result<std::shared_ptr<PoseBake>> PoseBake::prepare(World& world, Entity e, const SkinnedPoseAO& settings,
                                                    std::uint64_t seed, MemoryBudget& budget,
                                                    std::vector<std::string>* warnings) {
  const std::string context = entity_context(world, e);
  const Mesh* mesh = world.alive(e) ? world.try_get<Mesh>(e) : nullptr;
  if (mesh == nullptr || !mesh->data)
    return make_error(ErrorCode::InvalidInput, context + ": has no Mesh; put SkinnedPoseAO on a skinned mesh entity");
  auto rig = make_pose_rig(world, e, context);
  if (!rig) return rig.error();
  PENUMBRA_TRY(validate_pose_ao(settings, rig->joint_count(), context));
  const PoseSpace space = pose_space(*rig, settings);
  {
    const auto joint_name = [&](std::size_t j) {
      return j < rig->names.size() && !rig->names[j].empty() ? "'" + rig->names[j] + "'" : "joint " + std::to_string(j);
    };
    char figures[160];
    if (space.moving == 0) {
      std::snprintf(figures, sizeof figures, " turn no joint more than %.3g rad (%.2g rad is the least that counts)",
                    static_cast<double>(space.widest_range), static_cast<double>(kPoseMinJointRange));
      const bool given = space.source == PoseSpace::Source::JointRanges;
      return make_error(ErrorCode::InvalidArgument,
                        context + ": " + (given ? "joint_ranges" : "the ranges from default_range") + figures +
                            ": every reference pose would be the bind pose; give the joints that bend ranges of a "
                            "few tenths of a radian" + (given ? "" : " (default_range 0.5)"));
    }
    if (degenerate_clips(space.source)) {
      std::string clips;
      for (const AnimationClip* c : rig->clips) {
        std::snprintf(figures, sizeof figures, " (%.3g s)", static_cast<double>(c->duration));
        clips += (clips.empty() ? "'" : ", '") + c->name + "'" + figures;
      }
      char range[32];
      std::snprintf(range, sizeof range, "+-%.3g rad", static_cast<double>(settings.default_range));
      std::snprintf(figures, sizeof figures, "%.3g rad", static_cast<double>(space.clip_widest_range));
      const std::string instead =
          space.source == PoseSpace::Source::DegenerateClipsRoles
              ? "the ranges of the joints' roles by name (" + std::to_string(space.roles) + " of " +
                    std::to_string(rig->joint_count()) + " joints recognised, the others " + range + ")"
              : std::string(range) + " (default_range) on the " +
                    std::to_string(space.moving) + " joints they animate";
      const std::string message =
          context + ": the clips " + clips + " turn no joint more than " + figures +
          ": a degenerate pose space (every reference pose would be the bind pose); sampling " + instead +
          " instead; give the bake the character's animations (penumbra bake --poses FILE.glb) or set joint_ranges "
          "for its real range of motion";
      log(LogLevel::Warning, message);
      if (warnings) warnings->push_back(message);
    }
    std::snprintf(figures, sizeof figures, "%zu of %zu joints move, the widest %.3g rad", space.moving,
                  rig->joint_count(), static_cast<double>(space.widest_range));
    if (!space.unmatched_limits.empty()) {
      std::string patterns;
      for (const std::string& p : space.unmatched_limits) patterns += (patterns.empty() ? "'" : ", '") + p + "'";
      const std::string message = context + ": joint_limits " + patterns +
                                  " match no joint of the skin; check the names (" + joint_name(0) + " is one)";
      log(LogLevel::Warning, message);
      if (warnings) warnings->push_back(message);
    }
    std::string roles;
    if (space.roles > 0)
      roles = ", " + std::to_string(space.roles) + " joints by role (" + std::to_string(space.anatomical) +
              " swing and twist about the bone, the others +-their role's limit per axis)";
    if (space.limited > 0) roles += ", " + std::to_string(space.limited) + " by joint_limits";
    log(LogLevel::Info, context + ": pose space from " + to_string(space.source) + ": " + figures + " (" +
                            joint_name(space.widest) + ")" + roles);
  }
  std::vector<std::string> notes;
  std::vector<PoseAOOccluder> occluders = character_occluders(world, e, &notes);
  for (const std::string& note : notes) {
    log(LogLevel::Warning, context + ": " + note);
    if (warnings) warnings->push_back(context + ": " + note);
  }
  if (!occluders.empty())
    log(LogLevel::Info, context + ": traced with the character's " + std::to_string(occluders.size()) +
                            " other mesh" + (occluders.size() == 1 ? "" : "es"));
  if (settings.ground) occluders.push_back(ground_occluder(*mesh->data, occluders, world.get<WorldTransform>(e).matrix));
  auto tracer = PoseAOTracer::create(mesh->data, rig->joint_count(), context, std::move(occluders));
  if (!tracer) return tracer.error();

  const std::size_t V = mesh->data->positions.size(), J = rig->joint_count();
  const std::size_t P = settings.reference_poses + std::size_t{settings.clip_poses} * rig->clips.size();
  const std::uint64_t bytes = (P + 1) * (V + J * kPoseFeaturesPerJoint) * sizeof(float) * 2 +
                              V * (pose_ao_coefficients(kPoseAOMaxLocality) + 4) * sizeof(float);
  PENUMBRA_TRY(budget.reserve(context + " reference poses (" + std::to_string(P) + " poses x " + std::to_string(V) +
                                  " vertices; use fewer reference_poses)",
                              bytes));
  budget.release(bytes);

  auto bake = std::make_shared<PoseBake>();
  bake->context_ = context;
  bake->settings_ = settings;
  bake->settings_.data.reset();
  bake->mesh_ = mesh->data;
  bake->rig_ = std::move(*rig);
  bake->space_ = space;
  bake->tracer_.emplace(std::move(*tracer));
  bake->seed_ = seed;
  bake->vertices_ = V;
  bake->poses_ = P;
  return bake;
}

// What finish_pose_ao() reads of a character: the counts, the rig's hierarchy, the mesh's
// positions and skinning, the fit's settings and the pose space the poses came from.
struct PoseHeaderScalars {
  std::uint32_t vertices = 0, joints = 0, poses = 0;
  std::uint32_t locality = 0, rays_per_vertex = 0;
  float lambda = 0.0f;
  std::uint32_t pose_space = 0, moving_joints = 0;
  float widest_range = 0.0f;
  std::uint32_t clusters = 1;
};
static_assert(sizeof(PoseHeaderScalars) == 10 * 4, "written as its bytes: no padding");

std::vector<std::byte> PoseBake::header() const {
  ByteWriter w;
  w.write_string(context_);
  w.write(PoseHeaderScalars{static_cast<std::uint32_t>(vertices_), static_cast<std::uint32_t>(rig_.joint_count()),
                            static_cast<std::uint32_t>(poses_), settings_.locality, settings_.rays_per_vertex,
                            settings_.lambda, static_cast<std::uint32_t>(space_.source),
                            static_cast<std::uint32_t>(space_.moving), space_.widest_range, settings_.clusters});
  w.write_vector(rig_.parents);
  w.write_vector(mesh_->positions);
  w.write_vector(mesh_->joints);
  w.write_vector(mesh_->weights);
  return w.take();
}

Result<std::vector<std::byte>> PoseBake::run(std::uint64_t first, std::uint64_t last, JobContext& jobs) {
  const std::size_t V = vertices_, J = rig_.joint_count(), F = J * kPoseFeaturesPerJoint;
  const std::uint32_t rays = settings_.rays_per_vertex;
  ByteWriter out;
  std::vector<float> features(F), ao(V);
  jobs.begin_stage("pose-ao poses", (last - first) * V);
  for (std::uint64_t p = first; p < last; ++p) {
    if (p == 0) {
      // The bind pose: every skinning matrix the identity.
      const std::vector<glm::mat4> identity(J, glm::mat4(1.0f));
      std::fill(features.begin(), features.end(), 0.0f);
      PENUMBRA_TRY(tracer_->trace(identity, rays, seed_, jobs, ao));
    } else {
      const std::uint64_t r = p - 1;
      Pose pose;
      if (r < settings_.reference_poses) {
        pose = random_pose(rig_, space_.ranges, seed_, r);
      } else {
        const std::size_t c = static_cast<std::size_t>((r - settings_.reference_poses) / settings_.clip_poses);
        const auto k = static_cast<std::uint32_t>((r - settings_.reference_poses) % settings_.clip_poses);
        const float t = rig_.clips[c]->duration * (static_cast<float>(k) + 0.5f) / static_cast<float>(settings_.clip_poses);
        pose = clip_pose(rig_, c, t);
      }
      const std::vector<glm::mat4> matrices = skinning_matrices(rig_, pose);
      pose_features(rig_.parents, matrices, features);
      PENUMBRA_TRY(tracer_->trace(matrices, rays, seed_, jobs, ao));
    }
    out.write_array(std::span<const float>(features));
    out.write_array(std::span<const float>(ao));
  }
  return out.take();
}

// The fit (step 4) from a character's header and every pose's results.
Result<PoseAOData> finish_pose_ao(std::span<const std::byte> header_bytes, std::span<const std::byte> results,
                                  JobContext& jobs, std::vector<std::string>* warnings, std::string_view where) {
  ByteReader header(header_bytes, std::string(where) + " header");
  std::string context;
  PoseHeaderScalars h;
  PoseRig rig;
  MeshData mesh;
  PENUMBRA_TRY(header.read_string(context));
  PENUMBRA_TRY(header.read(h));
  PENUMBRA_TRY(header.read_vector(rig.parents, 65535));
  PENUMBRA_TRY(header.read_vector(mesh.positions));
  PENUMBRA_TRY(header.read_vector(mesh.joints));
  PENUMBRA_TRY(header.read_vector(mesh.weights));
  PENUMBRA_TRY(header.finish());
  const std::size_t V = h.vertices, J = h.joints, P = h.poses, F = J * kPoseFeaturesPerJoint;
  bool acyclic = rig.parents.size() == J;
  for (std::size_t j = 0; acyclic && j < J; ++j) {
    std::size_t steps = 0;
    for (std::int32_t a = static_cast<std::int32_t>(j); a >= 0 && acyclic; ++steps) {
      acyclic = steps <= J && static_cast<std::size_t>(a) < J;
      if (acyclic) a = rig.parents[static_cast<std::size_t>(a)];
    }
  }
  if (V == 0 || J == 0 || P == 0 || !acyclic || mesh.positions.size() != V || mesh.joints.size() != V ||
      mesh.weights.size() != V || std::uint64_t{V} * J > (std::uint64_t{1} << 26) || h.locality > kPoseAOMaxLocality ||
      h.clusters == 0 || h.clusters > kPoseAOMaxClusters ||
      !(h.lambda >= 0.0f) || !std::isfinite(h.lambda) ||
      h.pose_space > static_cast<std::uint32_t>(PoseSpaceSource::DegenerateClipsRoles) ||
      results.size() != (P + 1) * (F + V) * sizeof(float))
    return make_error(ErrorCode::InvalidInput, std::string(where) + ": the header (" + std::to_string(V) + " vertices, " +
                                                   std::to_string(J) + " joints, " + std::to_string(P) +
                                                   " poses) or the " + std::to_string(results.size()) +
                                                   " bytes of results do not describe a character; the part is "
                                                   "corrupt, re-bake it");
  PoseAOTraining training;
  training.vertex_count = V;
  training.joint_count = J;
  training.bind_ao.resize(V);
  training.features.resize(P * F);
  training.ao.resize(P * V);
  const auto floats_at = [&](std::size_t offset, std::span<float> out) {
    std::memcpy(out.data(), results.data() + offset * sizeof(float), out.size_bytes());
  };
  floats_at(F, training.bind_ao);
  for (std::size_t p = 0; p < P; ++p) {
    const std::size_t at = (p + 1) * (F + V);
    floats_at(at, std::span<float>(training.features).subspan(p * F, F));
    floats_at(at + F, std::span<float>(training.ao).subspan(p * V, V));
  }
  SkinnedPoseAO settings;
  settings.locality = h.locality;
  settings.lambda = h.lambda;
  settings.rays_per_vertex = h.rays_per_vertex;
  settings.clusters = h.clusters;
  auto data = fit_pose_ao(training, rig, mesh, settings, 0, jobs, warnings, context);
  if (!data) return data.error();
  data->pose_space = static_cast<PoseSpaceSource>(h.pose_space);
  data->moving_joints = h.moving_joints;
  data->widest_range = h.widest_range;
  return data;
}

}  // namespace

Result<PoseAOData> bake_pose_ao(World& world, Entity e, const SkinnedPoseAO& settings, std::uint64_t seed,
                                JobContext& jobs, MemoryBudget& budget, std::vector<std::string>* warnings) {
  auto bake = PoseBake::prepare(world, e, settings, seed, budget, warnings);
  if (!bake) return bake.error();
  auto results = (*bake)->run(0, (*bake)->elements(), jobs);
  if (!results) return results.error();
  return finish_pose_ao((*bake)->header(), *results, jobs, warnings, entity_context(world, e));
}

namespace {

// A group per skinned mesh with SkinnedPoseAO, one pose per work item.
Result<BakeWork> plan_pose_ao(BakeInputs& in) {
  const std::vector<Entity> meshes = pose_ao_meshes(in.world);
  auto keys = bake_keys(in, meshes, "pose-AO mesh");
  if (!keys) return keys.error();
  BakeWork work;
  auto bakes = std::make_shared<std::vector<std::shared_ptr<PoseBake>>>();
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const Entity e = meshes[i];
    auto bake = PoseBake::prepare(in.world, e, in.world.get<SkinnedPoseAO>(e), in.settings.seed, in.budget, nullptr);
    if (!bake) return bake.error();
    work.groups.push_back(
        BakeGroup{std::move((*keys)[i]), (*bake)->elements(), 1, (*bake)->element_cost(), (*bake)->header()});
    bakes->push_back(std::move(*bake));
  }
  work.run = [bakes](std::size_t g, std::uint64_t begin, std::uint64_t end, JobContext& jobs) {
    return (*bakes)[g]->run(begin, end, jobs);
  };
  return work;
}

// One PSAO chunk per character, in entity order.
Result<std::vector<BakeChunk>> finish_all(std::span<const BakedGroup> groups, JobContext& jobs) {
  std::vector<BakeChunk> chunks;
  for (const BakedGroup& g : groups) {
    auto data = finish_pose_ao(g.group->header, g.results, jobs, nullptr, "pose-AO '" + g.group->name + "'");
    if (!data) return data.error();
    data->key = g.group->name;
    chunks.push_back(write_pose_ao_chunk(*data));
  }
  return chunks;
}

// The rules that turn the settings into a bake (the roles' motions in pose_space, the ridge
// strengths the fit tries), in the inputs' hash so that a bake of an earlier rule reads as out of
// date.
constexpr std::uint32_t kPoseAORule = 3;

void hash_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kPoseAOChunkVersion);
  h.add(kPoseAORule);
  for (Entity e : pose_ao_meshes(world)) {
    const SkinnedPoseAO& s = world.get<SkinnedPoseAO>(e);
    h.add(std::string_view(entity_key(world, e)));
    hash_fields(skinned_pose_ao_info(), &s, h);
    h.add(s.joint_ranges);  // a list, not a field
    const Skin& skin = world.get<Skin>(e);
    h.add(skin.inverse_bind);
    // The rig as the bake reads it (make_pose_rig): the joints' hierarchy, the fixed offsets to
    // their parent nodes and their names (the roles and the joint_limits matches). Not the joints'
    // current local transforms: the poses are built from the bind pose, so a character's bake does
    // not depend on the animation time it is baked at. The offsets, and what follows from the
    // character's world matrices, are products of moving matrices: hashed rounded to 2^-16 (of a
    // metre, of a unit vector), so the float noise of the motion stays out of the hash.
    const auto add_rounded = [&h](const float* v, int n) {
      for (int i = 0; i < n; ++i) h.add(static_cast<std::int64_t>(std::llround(double(v[i]) * 65536.0)));
    };
    if (auto rig = make_pose_rig(world, e, "pose-ao")) {
      h.add(rig->parents);
      for (const glm::mat4& offset : rig->offsets) add_rounded(&offset[0][0], 16);
      for (const std::string& name : rig->names) h.add(std::string_view(name));
    } else {
      h.add(std::string_view(rig.error().message));
    }
    // The character's other meshes, traced with it: which, how they are bound and where they are
    // relative to this one (character_occluders).
    const glm::mat4 to_frame = glm::inverse(world.get<WorldTransform>(e).matrix);
    for (Entity other : character_meshes(world, e)) {
      h.add(std::string_view(entity_key(world, other)));
      h.add(world.get<Skin>(other).inverse_bind);
      if (const auto* wt = world.try_get<WorldTransform>(other)) {
        const glm::mat4 relative = to_frame * wt->matrix;
        add_rounded(&relative[0][0], 16);
      }
    }
    // The ground's plane: world up in the mesh frame (ground_occluder), which turning about up
    // and walking leave alone.
    if (s.ground) {
      glm::vec3 up = glm::transpose(glm::mat3(world.get<WorldTransform>(e).matrix)) * glm::vec3(0.0f, 1.0f, 0.0f);
      up /= std::max(glm::length(up), 1e-30f);
      add_rounded(&up.x, 3);
    }
    // The clips that drive the ranges: their keys.
    world.view<Animator>().each([&](Entity, Animator& a) {
      if (!a.clips) return;
      for (const AnimationClip& clip : *a.clips)
        for (const AnimationChannel& ch : clip.channels) {
          h.add(ch.target);
          h.add(static_cast<std::uint8_t>(ch.path));
          h.add(ch.times);
          h.add(ch.values);
        }
    });
  }
}

}  // namespace

void register_pose_ao_baker(World& world) {
  Baker b = baker_for(pose_ao_module());
  b.reads_lights = false;
  b.stages = 2;  // per mesh: poses, fit
  b.hash_inputs = hash_inputs;
  b.plan = plan_pose_ao;
  b.finish = finish_all;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
