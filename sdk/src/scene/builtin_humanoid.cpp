// The built-in production-style humanoid (builtin.h, add_builtin_humanoid): the shape of a
// character as the common pipelines export it, built procedurally so the tests need no asset.
//
// Skeleton: 65 joints named as Mixamo names them ("mixamorig:LeftForeArm"), under an "Armature"
// node scaled by 0.01 (joint translations, vertices and inverse bind matrices in centimetres).
// Bind pose: a T-pose facing +Z, no joint rotation, so the inverse bind matrix of a joint is the
// translation by minus its position. Geometry: a body of tapered tubes along the bones (skinned
// to the bone's joint, blended with its parent's across the joint) and a second mesh, "gear"
// (shoulder pads, knee pads, a belt), with the same skin: the gear shadows the body only when
// both meshes are traced together. Animation: one clip "Take 001" of two keys 0.067 s apart that
// turns no joint by more than 0.005 rad, as an export of a single frame does.
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"
#include "scene_node.h"

namespace penumbra {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

struct HumanoidJoint {
  std::string name;  // without the "mixamorig:" prefix
  int parent;        // index into the joint list, -1 for the hips
  glm::vec3 position;  // bind position, centimetres, armature frame
};

// The skeleton: spine and head, then per side the arm with five three-segment fingers and the
// leg. Left is +X (the character faces +Z).
std::vector<HumanoidJoint> humanoid_joints() {
  std::vector<HumanoidJoint> j;
  const auto add = [&j](std::string name, int parent, glm::vec3 p) {
    j.push_back({std::move(name), parent, p});
    return static_cast<int>(j.size()) - 1;
  };
  const int hips = add("Hips", -1, {0, 100, 0});
  const int spine = add("Spine", hips, {0, 110, 0});
  const int spine1 = add("Spine1", spine, {0, 122, 0});
  const int spine2 = add("Spine2", spine1, {0, 135, 0});
  const int neck = add("Neck", spine2, {0, 150, 0});
  const int head = add("Head", neck, {0, 160, 0});
  add("HeadTop_End", head, {0, 182, 0});
  for (const float side : {1.0f, -1.0f}) {
    const std::string s = side > 0 ? "Left" : "Right";
    const auto x = [side](float v) { return side * v; };
    const int shoulder = add(s + "Shoulder", spine2, {x(6), 145, 0});
    const int arm = add(s + "Arm", shoulder, {x(18), 145, 0});
    const int forearm = add(s + "ForeArm", arm, {x(46), 145, 0});
    const int hand = add(s + "Hand", forearm, {x(72), 145, 0});
    // Fingers: base offset from the hand and the three segment lengths along +-X (the thumb
    // points forward and down).
    struct Finger {
      const char* name;
      glm::vec3 base;
      glm::vec3 direction;
      std::array<float, 3> lengths;
    };
    const std::array<Finger, 5> fingers = {{
        {"Thumb", {2.0f, -2.0f, 3.0f}, glm::normalize(glm::vec3(0.6f, -0.25f, 0.75f)), {3.6f, 3.2f, 2.6f}},
        {"Index", {8.0f, 0.0f, 2.4f}, {1, 0, 0}, {4.0f, 2.6f, 2.0f}},
        {"Middle", {8.5f, 0.0f, 0.8f}, {1, 0, 0}, {4.5f, 3.0f, 2.2f}},
        {"Ring", {8.0f, 0.0f, -0.8f}, {1, 0, 0}, {4.2f, 2.8f, 2.0f}},
        {"Pinky", {7.0f, 0.0f, -2.4f}, {1, 0, 0}, {3.4f, 2.2f, 1.8f}},
    }};
    for (const Finger& f : fingers) {
      glm::vec3 p = glm::vec3(x(72 + f.base.x), 145 + f.base.y, f.base.z);
      const glm::vec3 d(side * f.direction.x, f.direction.y, f.direction.z);
      int up = add(s + "Hand" + f.name + "1", hand, p);
      for (int k = 0; k < 3; ++k) {
        p += d * f.lengths[static_cast<std::size_t>(k)];
        up = add(s + "Hand" + f.name + std::to_string(k + 2), up, p);
      }
    }
    const int upleg = add(s + "UpLeg", hips, {x(9), 95, 0});
    const int leg = add(s + "Leg", upleg, {x(9), 52, 0});
    const int foot = add(s + "Foot", leg, {x(9), 9, 0});
    const int toe = add(s + "ToeBase", foot, {x(9), 4, 12});
    add(s + "Toe_End", toe, {x(9), 4, 20});
  }
  return j;
}

// A tapered tube from a to b (radius r0 to r1, `around` sides, a ring every `ring_step` cm),
// skinned to `joint`, blended with `parent` across the first `blend` cm (half each at a). The
// tube starts 0.3 r0 before a so that neighbouring tubes overlap at the joint.
void append_tube(MeshData& mesh, glm::vec3 a, glm::vec3 b, float r0, float r1, int joint, int parent, float blend,
                 int around, float ring_step) {
  const glm::vec3 axis = glm::normalize(b - a);
  const glm::vec3 helper = std::abs(axis.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 u = glm::normalize(glm::cross(helper, axis)), w = glm::cross(axis, u);
  const float length = glm::length(b - a), start = -0.3f * r0;
  const int rings = std::max(2, static_cast<int>(std::ceil((length - start) / ring_step)));
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (int ring = 0; ring <= rings; ++ring) {
    const float s = start + (length - start) * static_cast<float>(ring) / static_cast<float>(rings);
    const float r = r0 + (r1 - r0) * std::clamp(s / length, 0.0f, 1.0f);
    const float own = parent == joint ? 1.0f : std::clamp(0.5f + 0.5f * s / blend, 0.0f, 1.0f);
    for (int k = 0; k < around; ++k) {
      const float angle = 2.0f * kPi * static_cast<float>(k) / static_cast<float>(around);
      const glm::vec3 n = std::cos(angle) * u + std::sin(angle) * w;
      mesh.positions.push_back(a + s * axis + r * n);
      mesh.normals.push_back(n);
      mesh.joints.push_back(glm::u16vec4(static_cast<std::uint16_t>(joint), static_cast<std::uint16_t>(parent), 0, 0));
      mesh.weights.push_back(parent == joint ? glm::vec4(1, 0, 0, 0) : glm::vec4(own, 1.0f - own, 0, 0));
    }
  }
  const auto n = static_cast<std::uint32_t>(around);
  for (std::uint32_t ring = 0; ring < static_cast<std::uint32_t>(rings); ++ring)
    for (std::uint32_t k = 0; k < n; ++k) {
      const std::uint32_t i0 = first + ring * n + k, i1 = first + ring * n + (k + 1) % n;
      const std::uint32_t i2 = i0 + n, i3 = i1 + n;
      // The angle turns from u towards w = axis x u: (i0, i1, i2) winds counter-clockwise seen
      // from outside.
      for (std::uint32_t i : {i0, i1, i2, i1, i3, i2}) mesh.indices.push_back(i);
    }
}

// A sphere of `radius` at `centre` skinned to `joint` (the head).
void append_sphere(MeshData& mesh, glm::vec3 centre, float radius, int joint) {
  const MeshData sphere = make_icosphere(radius, 3);
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (std::size_t i = 0; i < sphere.positions.size(); ++i) {
    mesh.positions.push_back(centre + sphere.positions[i]);
    mesh.normals.push_back(sphere.normals[i]);
    mesh.joints.push_back(glm::u16vec4(static_cast<std::uint16_t>(joint), 0, 0, 0));
    mesh.weights.push_back(glm::vec4(1, 0, 0, 0));
  }
  for (std::uint32_t i : sphere.indices) mesh.indices.push_back(first + i);
}

int find_joint(const std::vector<HumanoidJoint>& joints, const std::string& name) {
  for (std::size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  return -1;
}

MeshData humanoid_body(const std::vector<HumanoidJoint>& joints) {
  MeshData mesh;
  mesh.name = "body";
  const auto bone = [&](const std::string& from, const std::string& to, float r0, float r1, int around, float step) {
    const int j = find_joint(joints, from), c = find_joint(joints, to);
    const int parent = joints[static_cast<std::size_t>(j)].parent < 0 ? j : joints[static_cast<std::size_t>(j)].parent;
    const glm::vec3 a = joints[static_cast<std::size_t>(j)].position, b = joints[static_cast<std::size_t>(c)].position;
    append_tube(mesh, a, b, r0, r1, j, parent, std::min(r0, 0.3f * glm::length(b - a)), around, step);
  };
  // Pelvis: from below the hips to the spine, on the hips alone.
  append_tube(mesh, {0, 88, 0}, {0, 110, 0}, 15.0f, 14.0f, 0, 0, 1.0f, 24, 2.0f);
  bone("Spine", "Spine1", 14.0f, 15.0f, 24, 2.0f);
  bone("Spine1", "Spine2", 15.0f, 16.0f, 24, 2.0f);
  bone("Spine2", "Neck", 16.0f, 11.0f, 24, 2.0f);
  bone("Neck", "Head", 5.5f, 5.5f, 16, 2.0f);
  append_sphere(mesh, {0, 170, 0}, 11.0f, find_joint(joints, "Head"));
  for (const std::string s : {"Left", "Right"}) {
    bone(s + "Shoulder", s + "Arm", 6.0f, 6.0f, 16, 2.0f);
    bone(s + "Arm", s + "ForeArm", 5.5f, 4.5f, 16, 2.0f);
    bone(s + "ForeArm", s + "Hand", 4.2f, 3.2f, 16, 2.0f);
    bone(s + "Hand", s + "HandMiddle1", 3.2f, 3.0f, 16, 1.5f);
    for (const char* f : {"Thumb", "Index", "Middle", "Ring", "Pinky"})
      for (int k = 1; k <= 3; ++k)
        bone(s + "Hand" + f + std::to_string(k), s + "Hand" + f + std::to_string(k + 1), 0.9f, 0.75f, 8, 1.0f);
    bone(s + "UpLeg", s + "Leg", 8.0f, 6.0f, 24, 2.0f);
    bone(s + "Leg", s + "Foot", 5.5f, 4.0f, 16, 2.0f);
    bone(s + "Foot", s + "ToeBase", 4.0f, 3.5f, 16, 2.0f);
    bone(s + "ToeBase", s + "Toe_End", 3.5f, 3.0f, 16, 2.0f);
  }
  compute_bounds(mesh);
  return mesh;
}

// Sleeves over the upper arms (wide tubes 2.5 cm off the skin), knee pads and a belt: close to the
// body, so they occlude it.
MeshData humanoid_gear(const std::vector<HumanoidJoint>& joints) {
  MeshData mesh;
  mesh.name = "gear";
  const auto pad = [&](const std::string& joint, glm::vec3 a, glm::vec3 b, float r) {
    const int j = find_joint(joints, joint);
    const int parent = joints[static_cast<std::size_t>(j)].parent;
    append_tube(mesh, a, b, r, r, j, parent < 0 ? j : parent, 2.0f, 20, 1.5f);
  };
  for (const float side : {1.0f, -1.0f}) {
    const std::string s = side > 0 ? "Left" : "Right";
    pad(s + "Arm", {side * 17.0f, 146.5f, 0}, {side * 29.0f, 146.5f, 0}, 8.0f);
    // The knee pad from just above the knee (y 52) down the shin, blended across the knee.
    pad(s + "Leg", {side * 9.0f, 54.0f, 1.0f}, {side * 9.0f, 43.0f, 1.0f}, 7.5f);
  }
  pad("Hips", {0, 95.0f, 0}, {0, 102.0f, 0}, 16.5f);
  compute_bounds(mesh);
  return mesh;
}

}  // namespace

Entity add_builtin_humanoid(World& world, Entity parent, const Transform& transform, std::string_view name) {
  const auto node = [&world](Entity up, std::string node_name, const Transform& t) {
    return scene_detail::add_node(world, up, std::move(node_name), t);
  };
  const Entity character = node(parent, std::string(name), transform);
  Transform armature_transform;
  armature_transform.scale = glm::vec3(0.01f);
  const Entity armature = node(character, "Armature", armature_transform);

  const std::vector<HumanoidJoint> joints = humanoid_joints();
  std::vector<Entity> entities;
  Skin skin;
  for (const HumanoidJoint& j : joints) {
    const Entity up = j.parent < 0 ? armature : entities[static_cast<std::size_t>(j.parent)];
    const glm::vec3 parent_position = j.parent < 0 ? glm::vec3(0.0f) : joints[static_cast<std::size_t>(j.parent)].position;
    Transform t;
    t.translation = j.position - parent_position;
    entities.push_back(node(up, "mixamorig:" + j.name, t));
    skin.joints.push_back(entities.back());
    glm::mat4 inverse_bind(1.0f);
    inverse_bind[3] = glm::vec4(-j.position, 1.0f);
    skin.inverse_bind.push_back(inverse_bind);
  }
  const auto skinned = [&](std::string mesh_name, MeshData data, glm::vec3 albedo) {
    const Entity e = node(armature, std::move(mesh_name), Transform{});
    world.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(data))});
    Material m;
    m.base_color = glm::vec4(albedo, 1.0f);
    world.add<Material>(e, m);
    world.add<Skin>(e, skin);
  };
  skinned("body", humanoid_body(joints), {0.75f, 0.6f, 0.5f});
  skinned("gear", humanoid_gear(joints), {0.3f, 0.32f, 0.36f});

  // "Take 001": two keys 0.067 s apart on every joint, the bind rotation and a 0.005 rad turn
  // of the spine (what a one-frame export carries).
  AnimationClip clip;
  clip.name = "Take 001";
  clip.duration = 0.0667f;
  clip.targets = entities;
  for (std::size_t j = 0; j < joints.size(); ++j) {
    AnimationChannel ch;
    ch.target = static_cast<std::uint32_t>(j);
    ch.path = AnimationChannel::Path::Rotation;
    const glm::quat turn = glm::angleAxis(joints[j].name == "Spine" ? 0.005f : 0.0f, glm::vec3(0, 1, 0));
    ch.times = {0.0f, clip.duration};
    ch.values = {glm::vec4(0, 0, 0, 1), glm::vec4(turn.x, turn.y, turn.z, turn.w)};
    clip.channels.push_back(std::move(ch));
  }
  auto clips = std::make_shared<std::vector<AnimationClip>>();
  clips->push_back(std::move(clip));
  Animator animator;
  animator.clips = std::move(clips);
  world.add<Animator>(character, std::move(animator));
  return character;
}

bool add_builtin_humanoid_walk(World& world, Entity humanoid) {
  const Animator* animator = world.try_get<Animator>(humanoid);
  if (!animator || !animator->clips || animator->clips->empty()) return false;
  const std::vector<Entity>& joints = animator->clips->front().targets;
  const auto find = [&](std::string_view name) {
    for (std::size_t j = 0; j < joints.size(); ++j)
      if (const Name* n = world.try_get<Name>(joints[j]); n && n->value == "mixamorig:" + std::string(name))
        return static_cast<std::int64_t>(j);
    return std::int64_t{-1};
  };
  AnimationClip walk;
  walk.name = "Walk";
  walk.duration = 1.0f;
  walk.targets = joints;
  constexpr int kKeys = 9;
  // Each joint's local rotation at phase phi (the bind pose has none, so these are the rotations).
  const std::pair<std::string_view, glm::quat (*)(float)> curves[] = {
      {"Hips", [](float phi) { return glm::angleAxis(0.1f * std::sin(phi), glm::vec3(0, 1, 0)); }},
      {"Spine", [](float phi) { return glm::angleAxis(-0.1f * std::sin(phi), glm::vec3(0, 1, 0)); }},
      {"LeftArm", [](float phi) {
         return glm::angleAxis(0.35f * std::sin(phi), glm::vec3(1, 0, 0)) * glm::angleAxis(-1.2f, glm::vec3(0, 0, 1));
       }},
      {"RightArm", [](float phi) {
         return glm::angleAxis(-0.35f * std::sin(phi), glm::vec3(1, 0, 0)) * glm::angleAxis(1.2f, glm::vec3(0, 0, 1));
       }},
      {"LeftForeArm", [](float phi) { return glm::angleAxis(-(0.45f + 0.15f * std::sin(phi)), glm::vec3(0, 1, 0)); }},
      {"RightForeArm", [](float phi) { return glm::angleAxis(0.45f - 0.15f * std::sin(phi), glm::vec3(0, 1, 0)); }},
      {"LeftUpLeg", [](float phi) { return glm::angleAxis(-0.45f * std::sin(phi), glm::vec3(1, 0, 0)); }},
      {"RightUpLeg", [](float phi) { return glm::angleAxis(0.45f * std::sin(phi), glm::vec3(1, 0, 0)); }},
      {"LeftLeg", [](float phi) { return glm::angleAxis(0.35f + 0.3f * std::sin(phi + 1.2f), glm::vec3(1, 0, 0)); }},
      {"RightLeg", [](float phi) { return glm::angleAxis(0.35f - 0.3f * std::sin(phi + 1.2f), glm::vec3(1, 0, 0)); }},
  };
  for (const auto& [name, curve] : curves) {
    const std::int64_t j = find(name);
    if (j < 0) return false;
    AnimationChannel ch;
    ch.target = static_cast<std::uint32_t>(j);
    ch.path = AnimationChannel::Path::Rotation;
    for (int k = 0; k < kKeys; ++k) {
      const float t = walk.duration * static_cast<float>(k) / static_cast<float>(kKeys - 1);
      const glm::quat q = curve(2.0f * kPi * t / walk.duration);
      ch.times.push_back(t);
      ch.values.push_back(glm::vec4(q.x, q.y, q.z, q.w));
    }
    walk.channels.push_back(std::move(ch));
  }
  auto clips = std::make_shared<std::vector<AnimationClip>>(*animator->clips);
  clips->push_back(std::move(walk));
  world.patch<Animator>(humanoid).clips = std::move(clips);
  return true;
}

}  // namespace penumbra
