// Built-in scenes: the Cornell Box, a courtyard with a procedural skinned character, and the
// white furnace, a maze of large quads. See builtin.h for what each contains and why.
#include "penumbra/scene/builtin.h"

#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"
#include "scene_node.h"

namespace penumbra {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

Transform at(glm::vec3 translation, glm::quat rotation = glm::quat(1, 0, 0, 0)) {
  Transform t;
  t.translation = translation;
  t.rotation = rotation;
  return t;
}

// Creates entities under one root and keeps the counts of LoadedScene.
class SceneBuilder {
 public:
  SceneBuilder(World& world, std::string name) : world_(world) {
    scene_.name = std::move(name);
    scene_.root = node(Entity::null(), scene_.name, Transform{});
  }

  Entity node(Entity parent, std::string name, const Transform& transform) {
    return scene_detail::add_node(world_, parent, std::move(name), transform);
  }
  Entity node(std::string name, const Transform& transform) { return node(scene_.root, std::move(name), transform); }

  // An entity with geometry; `is_static` adds the Static tag.
  Entity mesh(Entity parent, std::string name, std::shared_ptr<const MeshData> data, const Material& material,
              const Transform& transform, bool is_static) {
    const Entity e = node(parent, std::move(name), transform);
    scene_.triangles += data->triangle_count();
    ++scene_.mesh_entities;
    world_.add<Mesh>(e, Mesh{std::move(data)});
    world_.add<Material>(e, material);
    if (is_static) world_.add<Static>(e);
    return e;
  }
  Entity mesh(std::string name, MeshData data, const Material& material, const Transform& transform = {},
              bool is_static = true) {
    return mesh(scene_.root, std::move(name), std::make_shared<const MeshData>(std::move(data)), material,
                transform, is_static);
  }

  Entity camera(const Transform& transform, const Camera& camera) {
    const Entity e = node("camera", transform);
    world_.add<Camera>(e, camera);
    if (!scene_.camera) scene_.camera = e;
    return e;
  }

  World& world() { return world_; }
  // Counts a mesh entity made without mesh() (the character's).
  void count_mesh(std::size_t triangles) {
    scene_.triangles += triangles;
    ++scene_.mesh_entities;
  }
  Entity root() const { return scene_.root; }
  LoadedScene finish() { return std::move(scene_); }

 private:
  World& world_;
  LoadedScene scene_;
};

Material lambert(glm::vec3 albedo) {
  Material m;
  m.base_color = glm::vec4(albedo, 1.0f);
  return m;
}

// ---------------------------------------------------------------------------------------------
// Cornell Box. Geometry: "Cornell Box Data", Cornell University Program of Computer Graphics
// (https://www.graphics.cornell.edu/online/box/data.html), in millimetres, converted to metres.
// Reflectances: the published data are spectral (400-700 nm). Integrating them against the CIE
// 1931 observer under an equal-energy illuminant and converting XYZ to linear sRGB gives the RGB
// values in wide use (pbrt, Mitsuba and the Benedikt Bitterli scene collection); we take those
// values as published rather than re-deriving them: white 0.73, red (0.63, 0.065, 0.05), green
// (0.14, 0.45, 0.091). Light: the published emission spectrum, reduced the same way, is commonly
// taken as radiance (17, 12, 4) W/(m^2 sr).
constexpr glm::vec3 kCornellWhite(0.73f, 0.73f, 0.73f);
constexpr glm::vec3 kCornellRed(0.63f, 0.065f, 0.05f);
constexpr glm::vec3 kCornellGreen(0.14f, 0.45f, 0.091f);
constexpr glm::vec3 kCornellLightRadiance(17.0f, 12.0f, 4.0f);

using Quad = std::array<glm::vec3, 4>;

// Flat-shaded mesh from quads (millimetres); each quad's triangles are wound so that their normal
// points along `facing(centre of the quad)`.
template <class Facing>
MeshData quads_mesh(std::string name, const std::vector<Quad>& quads, Facing facing) {
  MeshData mesh;
  mesh.name = std::move(name);
  for (const Quad& q : quads) {
    std::array<glm::vec3, 4> p;
    for (int i = 0; i < 4; ++i) p[static_cast<std::size_t>(i)] = q[static_cast<std::size_t>(i)] * 0.001f;
    const glm::vec3 centre = 0.25f * (p[0] + p[1] + p[2] + p[3]);
    glm::vec3 n = glm::normalize(glm::cross(p[1] - p[0], p[2] - p[0]) + glm::cross(p[2] - p[0], p[3] - p[0]));
    const bool flip = glm::dot(n, facing(centre)) < 0.0f;
    if (flip) n = -n;
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    for (const glm::vec3& v : p) {
      mesh.positions.push_back(v);
      mesh.normals.push_back(n);
    }
    const std::array<std::uint32_t, 6> order = flip ? std::array<std::uint32_t, 6>{0, 2, 1, 0, 3, 2}
                                                    : std::array<std::uint32_t, 6>{0, 1, 2, 0, 2, 3};
    for (std::uint32_t i : order) mesh.indices.push_back(base + i);
  }
  compute_bounds(mesh);
  return mesh;
}

LoadedScene build_cornell(World& world) {
  SceneBuilder b(world, "cornell");
  const glm::vec3 room_centre(0.278f, 0.2744f, 0.2796f);
  auto inward = [&](glm::vec3 c) { return room_centre - c; };
  auto room = [&](std::string name, Quad q, glm::vec3 albedo) {
    b.mesh(std::move(name), quads_mesh(name, {q}, inward), lambert(albedo));
  };
  room("floor", {{{552.8f, 0, 0}, {0, 0, 0}, {0, 0, 559.2f}, {549.6f, 0, 559.2f}}}, kCornellWhite);
  room("ceiling", {{{556.0f, 548.8f, 0}, {556.0f, 548.8f, 559.2f}, {0, 548.8f, 559.2f}, {0, 548.8f, 0}}}, kCornellWhite);
  room("back_wall", {{{549.6f, 0, 559.2f}, {0, 0, 559.2f}, {0, 548.8f, 559.2f}, {556.0f, 548.8f, 559.2f}}}, kCornellWhite);
  room("green_wall", {{{0, 0, 559.2f}, {0, 0, 0}, {0, 548.8f, 0}, {0, 548.8f, 559.2f}}}, kCornellGreen);
  room("red_wall", {{{552.8f, 0, 0}, {549.6f, 0, 559.2f}, {556.0f, 548.8f, 559.2f}, {556.0f, 548.8f, 0}}}, kCornellRed);

  // The blocks: a top and four sides each, wound to face away from the block's axis.
  auto block = [&](std::string name, const std::vector<Quad>& quads, glm::vec3 centre_mm) {
    const glm::vec3 centre = centre_mm * 0.001f;
    auto outward = [&](glm::vec3 c) { return glm::vec3(c.x - centre.x, c.y - centre.y, c.z - centre.z); };
    b.mesh(name, quads_mesh(name, quads, outward), lambert(kCornellWhite));
  };
  block("short_block",
        {{{{130, 165, 65}, {82, 165, 225}, {240, 165, 272}, {290, 165, 114}}},
         {{{290, 0, 114}, {290, 165, 114}, {240, 165, 272}, {240, 0, 272}}},
         {{{130, 0, 65}, {130, 165, 65}, {290, 165, 114}, {290, 0, 114}}},
         {{{82, 0, 225}, {82, 165, 225}, {130, 165, 65}, {130, 0, 65}}},
         {{{240, 0, 272}, {240, 165, 272}, {82, 165, 225}, {82, 0, 225}}}},
        {185.5f, 82.5f, 169.0f});
  block("tall_block",
        {{{{423, 330, 247}, {265, 330, 296}, {314, 330, 456}, {472, 330, 406}}},
         {{{423, 0, 247}, {423, 330, 247}, {472, 330, 406}, {472, 0, 406}}},
         {{{472, 0, 406}, {472, 330, 406}, {314, 330, 456}, {314, 0, 456}}},
         {{{314, 0, 456}, {314, 330, 456}, {265, 330, 296}, {265, 0, 296}}},
         {{{265, 0, 296}, {265, 330, 296}, {423, 330, 247}, {423, 0, 247}}}},
        {368.5f, 165.0f, 351.5f});

  // The light: x 213..343 mm, z 227..332 mm, 0.1 mm under the ceiling, facing down (local -Z -> -Y;
  // local X -> -X, local Y -> +Z).
  Light light;
  light.type = Light::Type::Rect;
  light.intensity = kCornellLightRadiance.x;
  light.color = kCornellLightRadiance / kCornellLightRadiance.x;
  light.size = glm::vec2(0.130f, 0.105f);
  const Entity light_entity = b.node("light", at({0.278f, 0.5487f, 0.2795f},
                                                 glm::quatLookAt(glm::vec3(0, -1, 0), glm::vec3(0, 0, 1))));
  world.add<Light>(light_entity, light);

  // Camera: at (278, 273, -800) mm looking +Z; 35 mm lens on a 25 mm film: yfov = 2 atan(12.5 / 35).
  Camera camera;
  camera.yfov = 2.0f * std::atan(12.5f / 35.0f);
  camera.aspect = 1.0f;
  camera.znear = 0.01f;
  camera.zfar = 10.0f;
  b.camera(at({0.278f, 0.273f, -0.800f}, glm::quatLookAt(glm::vec3(0, 0, 1), glm::vec3(0, 1, 0))), camera);
  return b.finish();
}

// ---------------------------------------------------------------------------------------------
// Furnace: inward icosphere, 4 subdivisions (5,120 triangles, faceting error in the radius < 0.2%).
LoadedScene build_furnace(World& world) {
  SceneBuilder b(world, "furnace");
  Material m = lambert(glm::vec3(kFurnaceAlbedo));
  m.emissive = glm::vec3(kFurnaceRadiance);
  b.mesh("sphere", make_icosphere(kFurnaceRadius, 4, /*inward=*/true, "furnace"), m);
  b.camera(at(glm::vec3(0.0f)), Camera{});
  return b.finish();
}

// ---------------------------------------------------------------------------------------------
// Courtyard character: 8 joints, every limb vertical in the bind pose so each limb is a tube
// along +Y, weighted to its two joints across a blend band at the bending joint.
enum Joint : std::uint16_t { kHips, kSpine, kLeftThigh, kLeftShin, kRightThigh, kRightShin, kLeftArm, kRightArm, kJointCount };

struct JointDef {
  const char* name;
  int parent;           // -1: child of the character root
  glm::vec3 position;   // bind position in the character's frame
};
constexpr std::array<JointDef, kJointCount> kJoints = {{
    {"hips", -1, {0.0f, 0.90f, 0.0f}},
    {"spine", kHips, {0.0f, 1.20f, 0.0f}},
    {"left_thigh", kHips, {0.12f, 0.90f, 0.0f}},
    {"left_shin", kLeftThigh, {0.12f, 0.48f, 0.0f}},
    {"right_thigh", kHips, {-0.12f, 0.90f, 0.0f}},
    {"right_shin", kRightThigh, {-0.12f, 0.48f, 0.0f}},
    {"left_arm", kSpine, {0.24f, 1.45f, 0.0f}},
    {"right_arm", kSpine, {-0.24f, 1.45f, 0.0f}},
}};

// A tube of radius r around the vertical line through `base` from y0 to y1; vertices above
// `blend_y` belong to `upper`, below to `lower`, mixed linearly within +-blend_half of it.
void append_tube(MeshData& mesh, glm::vec2 base_xz, float y0, float y1, float r, Joint lower, Joint upper,
                 float blend_y, float blend_half) {
  constexpr std::uint32_t kSegments = 12, kRings = 10;
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (std::uint32_t ring = 0; ring <= kRings; ++ring) {
    const float y = y0 + (y1 - y0) * static_cast<float>(ring) / static_cast<float>(kRings);
    const float w_upper = std::clamp((y - (blend_y - blend_half)) / (2.0f * blend_half), 0.0f, 1.0f);
    for (std::uint32_t s = 0; s < kSegments; ++s) {
      const float a = 2.0f * kPi * static_cast<float>(s) / static_cast<float>(kSegments);
      const glm::vec3 n(std::cos(a), 0.0f, std::sin(a));
      mesh.positions.push_back(glm::vec3(base_xz.x, y, base_xz.y) + r * n);
      mesh.normals.push_back(n);
      mesh.joints.push_back(glm::u16vec4(upper, lower, 0, 0));
      mesh.weights.push_back(glm::vec4(w_upper, 1.0f - w_upper, 0.0f, 0.0f));
    }
  }
  for (std::uint32_t ring = 0; ring < kRings; ++ring)
    for (std::uint32_t s = 0; s < kSegments; ++s) {
      const std::uint32_t a = first + ring * kSegments + s, b = first + ring * kSegments + (s + 1) % kSegments;
      const std::uint32_t c = a + kSegments, d = b + kSegments;
      // Angle grows from +X towards +Z; (a, c, b) faces outward (see make_cylinder).
      for (std::uint32_t i : {a, c, b, b, c, d}) mesh.indices.push_back(i);
    }
}

MeshData character_mesh() {
  MeshData mesh;
  mesh.name = "character";
  append_tube(mesh, {0.0f, 0.0f}, 0.85f, 1.60f, 0.16f, kHips, kSpine, 1.15f, 0.08f);        // torso
  append_tube(mesh, {0.12f, 0.0f}, 0.0f, 0.90f, 0.07f, kLeftShin, kLeftThigh, 0.48f, 0.06f);  // legs
  append_tube(mesh, {-0.12f, 0.0f}, 0.0f, 0.90f, 0.07f, kRightShin, kRightThigh, 0.48f, 0.06f);
  append_tube(mesh, {0.24f, 0.0f}, 0.85f, 1.45f, 0.05f, kLeftArm, kLeftArm, 1.0f, 0.1f);     // arms
  append_tube(mesh, {-0.24f, 0.0f}, 0.85f, 1.45f, 0.05f, kRightArm, kRightArm, 1.0f, 0.1f);
  // Head: a small icosphere riding on the spine.
  const MeshData head = make_icosphere(0.11f, 2);
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (std::size_t i = 0; i < head.positions.size(); ++i) {
    mesh.positions.push_back(head.positions[i] + glm::vec3(0.0f, 1.72f, 0.0f));
    mesh.normals.push_back(head.normals[i]);
    mesh.joints.push_back(glm::u16vec4(kSpine, 0, 0, 0));
    mesh.weights.push_back(glm::vec4(1.0f, 0.0f, 0.0f, 0.0f));
  }
  for (std::uint32_t i : head.indices) mesh.indices.push_back(first + i);
  compute_bounds(mesh);
  return mesh;
}

// Walk cycle, 1 s, LINEAR keys every 1/8 s: thighs and arms swing in opposition, knees bend,
// hips bob twice per cycle. The last key equals the first, so looping is seamless.
AnimationClip walk_clip(const std::array<Entity, kJointCount>& joints) {
  AnimationClip clip;
  clip.name = "walk";
  clip.duration = 1.0f;
  clip.targets.assign(joints.begin(), joints.end());
  constexpr int kKeys = 9;
  auto rotation_channel = [&](Joint joint, auto angle_of) {
    AnimationChannel ch;
    ch.target = joint;
    ch.path = AnimationChannel::Path::Rotation;
    for (int k = 0; k < kKeys; ++k) {
      const float t = static_cast<float>(k) / static_cast<float>(kKeys - 1);
      const glm::quat q = glm::angleAxis(angle_of(2.0f * kPi * t), glm::vec3(1, 0, 0));
      ch.times.push_back(t);
      ch.values.push_back(glm::vec4(q.x, q.y, q.z, q.w));
    }
    clip.channels.push_back(std::move(ch));
  };
  rotation_channel(kLeftThigh, [](float p) { return 0.5f * std::sin(p); });
  rotation_channel(kRightThigh, [](float p) { return -0.5f * std::sin(p); });
  rotation_channel(kLeftShin, [](float p) { return -0.3f * (1.0f + std::sin(p)); });
  rotation_channel(kRightShin, [](float p) { return -0.3f * (1.0f - std::sin(p)); });
  rotation_channel(kLeftArm, [](float p) { return -0.4f * std::sin(p); });
  rotation_channel(kRightArm, [](float p) { return 0.4f * std::sin(p); });
  AnimationChannel bob;
  bob.target = kHips;
  bob.path = AnimationChannel::Path::Translation;
  for (int k = 0; k < kKeys; ++k) {
    const float t = static_cast<float>(k) / static_cast<float>(kKeys - 1);
    bob.times.push_back(t);
    bob.values.push_back(glm::vec4(kJoints[kHips].position + glm::vec3(0, 0.02f * std::cos(4.0f * kPi * t), 0), 0));
  }
  clip.channels.push_back(std::move(bob));
  return clip;
}

}  // namespace

Entity add_builtin_character(World& world, Entity parent, const Transform& transform, std::string_view name) {
  const auto node = [&world](Entity up, std::string node_name, const Transform& t) {
    return scene_detail::add_node(world, up, std::move(node_name), t);
  };
  const Entity character = node(parent, std::string(name), transform);
  // Joints: entities of the hierarchy with translations relative to their parent joint.
  std::array<Entity, kJointCount> joints;
  Skin skin;
  for (std::size_t j = 0; j < kJointCount; ++j) {
    const JointDef& def = kJoints[j];
    const Entity up = def.parent < 0 ? character : joints[static_cast<std::size_t>(def.parent)];
    const glm::vec3 parent_position = def.parent < 0 ? glm::vec3(0.0f) : kJoints[static_cast<std::size_t>(def.parent)].position;
    joints[j] = node(up, def.name, at(def.position - parent_position));
    skin.joints.push_back(joints[j]);
    // Bind pose has no rotation: the inverse bind matrix undoes the joint's bind translation.
    glm::mat4 inverse_bind(1.0f);
    inverse_bind[3] = glm::vec4(-def.position, 1.0f);
    skin.inverse_bind.push_back(inverse_bind);
  }
  const Entity body = node(character, "character_mesh", Transform{});
  world.add<Mesh>(body, Mesh{std::make_shared<const MeshData>(character_mesh())});
  world.add<Material>(body, lambert({0.8f, 0.55f, 0.45f}));
  world.add<Skin>(body, std::move(skin));
  auto clips = std::make_shared<std::vector<AnimationClip>>();
  clips->push_back(walk_clip(joints));
  Animator animator;
  animator.clips = std::move(clips);
  world.add<Animator>(character, std::move(animator));
  return character;
}

namespace {

LoadedScene build_courtyard(World& world) {
  SceneBuilder b(world, "courtyard");
  const Material stone = lambert({0.6f, 0.58f, 0.55f});
  const Material plaster = lambert({0.75f, 0.72f, 0.68f});
  const Material wood = lambert({0.55f, 0.38f, 0.22f});

  // Ground: 20 x 20 m slab with its top at y = 0.
  b.mesh("ground", make_box({10.0f, 0.05f, 10.0f}, "ground"), lambert({0.45f, 0.42f, 0.38f}), at({0, -0.05f, 0}));
  // Perimeter walls on the north (-Z) and west (-X) sides, 3 m high, 30 cm thick.
  b.mesh("north_wall", make_box({10.0f, 1.5f, 0.15f}, "north_wall"), plaster, at({0, 1.5f, -9.85f}));
  b.mesh("west_wall", make_box({0.15f, 1.5f, 9.7f}, "west_wall"), plaster, at({-9.85f, 1.5f, 0.15f}));
  // Thin wall: 5 cm thick, 4 m long, 2.5 m high, free-standing with open ground on both sides.
  b.mesh("thin_wall", make_box({2.0f, 1.25f, 0.025f}, "thin_wall"), plaster, at({3.0f, 1.25f, -2.0f}));
  // Pillars: four columns 3 m high sharing one mesh.
  auto pillar = std::make_shared<const MeshData>(make_cylinder(0.25f, 3.0f, 16, "pillar"));
  for (glm::vec3 p : {glm::vec3(-5, 0, -5), glm::vec3(-5, 0, 0), glm::vec3(-5, 0, 5), glm::vec3(6, 0, 5)})
    b.mesh(b.root(), "pillar", pillar, stone, at(p), true);
  // Arch: two posts and a semicircle of nine voussoirs (inner radius 1.3 m) spanning x in [-1.7, 1.7] at z = 6.
  const Entity arch = b.node("arch", at({0.0f, 0.0f, 6.0f}));
  auto post = std::make_shared<const MeshData>(make_box({0.2f, 1.25f, 0.3f}, "arch_post"));
  b.mesh(arch, "arch_post", post, stone, at({-1.5f, 1.25f, 0.0f}), true);
  b.mesh(arch, "arch_post", post, stone, at({1.5f, 1.25f, 0.0f}), true);
  auto voussoir = std::make_shared<const MeshData>(make_box({0.2f, 0.24f, 0.3f}, "voussoir"));
  for (int i = 0; i < 9; ++i) {
    const float a = kPi * (static_cast<float>(i) + 0.5f) / 9.0f;  // from +X over the top to -X
    const glm::vec3 centre(1.5f * std::cos(a), 2.5f + 1.5f * std::sin(a), 0.0f);
    b.mesh(arch, "voussoir", voussoir, stone, at(centre, glm::angleAxis(a, glm::vec3(0, 0, 1))), true);
  }
  // Crates: movable props (no Static tag), sharing one mesh.
  auto crate = std::make_shared<const MeshData>(make_box(glm::vec3(0.4f), "crate"));
  for (glm::vec3 p : {glm::vec3(1.0f, 0.4f, 2.0f), glm::vec3(2.0f, 0.4f, 2.3f), glm::vec3(1.5f, 1.2f, 2.1f),
                      glm::vec3(-3.0f, 0.4f, -6.0f)})
    b.mesh(b.root(), "crate", crate, wood, at(p), false);

  // Lights: the sun (illuminance 3 W/m^2 from above, south-east) and a warm point light.
  Light sun;
  sun.type = Light::Type::Directional;
  sun.intensity = 3.0f;
  sun.color = {1.0f, 0.95f, 0.85f};
  world.add<Light>(b.node("sun", at({0, 10, 0}, glm::quatLookAt(glm::normalize(glm::vec3(-0.4f, -1.0f, -0.3f)),
                                                                  glm::vec3(0, 0, -1)))),
                   sun);
  Light lamp;
  lamp.type = Light::Type::Point;
  lamp.intensity = 20.0f;
  lamp.color = {1.0f, 0.8f, 0.6f};
  lamp.range = 12.0f;
  world.add<Light>(b.node("lamp", at({-2.0f, 2.5f, 3.0f})), lamp);
  // A clear sky: uniform radiance giving an open floor pi L = 0.57-1.0 W/m^2, a quarter of the sun's.
  world.add<Environment>(b.node("sky", at({0, 0, 0})), Environment{{0.18f, 0.23f, 0.32f}});

  add_builtin_character(world, b.root(), at({2.0f, 0.0f, 4.0f}));
  b.count_mesh(character_mesh().triangle_count());

  Camera camera;
  camera.yfov = 1.0f;
  b.camera(at({0.0f, 2.0f, 9.5f}, glm::angleAxis(-0.12f, glm::vec3(1, 0, 0))), camera);
  return b.finish();
}

// ---------------------------------------------------------------------------------------------
// Maze: the kind of scene wavelet radiance transport was shown on (Kontkanen et al. 2006): large
// quads only, a 12 x 8 m room 2.5 m tall cut into corridors by three coloured interior walls
// (20 cm thick boxes), and a warm point light that an Animator carries along a path through the
// gaps and back (a 12 s loop).
constexpr float kMazeHeight = 2.5f;

// An axis-aligned wall box of thickness 0.2 m from (x0, z0) to (x1, z1) (one of them equal),
// floor to ceiling, in millimetres for quads_mesh; `caps` adds the end faces.
std::vector<Quad> maze_wall(float x0, float z0, float x1, float z1, bool cap_start, bool cap_end) {
  const float h = kMazeHeight * 1000.0f, t = 100.0f;
  const bool along_z = x0 == x1;
  std::vector<Quad> q;
  const auto mm = [](float v) { return v * 1000.0f; };
  if (along_z) {
    const float x = mm(x0), a = mm(z0), b = mm(z1);
    q.push_back({{{x - t, 0, a}, {x - t, 0, b}, {x - t, h, b}, {x - t, h, a}}});
    q.push_back({{{x + t, 0, a}, {x + t, h, a}, {x + t, h, b}, {x + t, 0, b}}});
    if (cap_start) q.push_back({{{x - t, 0, a}, {x - t, h, a}, {x + t, h, a}, {x + t, 0, a}}});
    if (cap_end) q.push_back({{{x - t, 0, b}, {x + t, 0, b}, {x + t, h, b}, {x - t, h, b}}});
  } else {
    const float z = mm(z0), a = mm(x0), b = mm(x1);
    q.push_back({{{a, 0, z - t}, {a, h, z - t}, {b, h, z - t}, {b, 0, z - t}}});
    q.push_back({{{a, 0, z + t}, {b, 0, z + t}, {b, h, z + t}, {a, h, z + t}}});
    if (cap_start) q.push_back({{{a, 0, z - t}, {a, 0, z + t}, {a, h, z + t}, {a, h, z - t}}});
    if (cap_end) q.push_back({{{b, 0, z - t}, {b, h, z - t}, {b, h, z + t}, {b, 0, z + t}}});
  }
  return q;
}

LoadedScene build_maze(World& world) {
  SceneBuilder b(world, "maze");
  const float w = 12000.0f, d = 8000.0f, h = kMazeHeight * 1000.0f;
  const glm::vec3 centre(6.0f, 1.25f, 4.0f);
  auto inward = [&](glm::vec3 c) { return centre - c; };
  b.mesh("floor", quads_mesh("floor", {{{{0, 0, 0}, {0, 0, d}, {w, 0, d}, {w, 0, 0}}}}, inward),
         lambert({0.60f, 0.55f, 0.50f}));
  b.mesh("ceiling", quads_mesh("ceiling", {{{{0, h, 0}, {w, h, 0}, {w, h, d}, {0, h, d}}}}, inward),
         lambert({0.80f, 0.80f, 0.80f}));
  b.mesh("outer_walls",
         quads_mesh("outer_walls",
                    {{{{0, 0, 0}, {w, 0, 0}, {w, h, 0}, {0, h, 0}}},
                     {{{0, 0, d}, {0, h, d}, {w, h, d}, {w, 0, d}}},
                     {{{0, 0, 0}, {0, h, 0}, {0, h, d}, {0, 0, d}}},
                     {{{w, 0, 0}, {w, 0, d}, {w, h, d}, {w, h, 0}}}},
                    inward),
         lambert({0.75f, 0.75f, 0.75f}));
  const auto wall = [&](std::string name, float x0, float z0, float x1, float z1, bool cap_start, bool cap_end,
                        glm::vec3 albedo) {
    const glm::vec3 axis(0.5f * (x0 + x1), 1.25f, 0.5f * (z0 + z1));
    auto outward = [axis, x0, x1](glm::vec3 c) {
      // Away from the wall's mid-plane; end caps away from its middle.
      glm::vec3 v = c - axis;
      v.y = 0.0f;
      if (x0 == x1 && std::abs(c.x - axis.x) < 0.05f) v.x = 0.0f;
      if (x0 != x1 && std::abs(c.z - axis.z) < 0.05f) v.z = 0.0f;
      return v;
    };
    b.mesh(name, quads_mesh(name, maze_wall(x0, z0, x1, z1, cap_start, cap_end), outward), lambert(albedo));
  };
  wall("red_wall", 4.0f, 0.0f, 4.0f, 5.0f, false, true, {0.70f, 0.12f, 0.08f});
  wall("green_wall", 8.0f, 3.0f, 8.0f, 8.0f, true, false, {0.12f, 0.60f, 0.15f});
  wall("blue_wall", 0.0f, 5.5f, 1.6f, 5.5f, false, true, {0.12f, 0.18f, 0.70f});

  // The lantern: a point light carried through the corridors and back.
  Light light;
  light.type = Light::Type::Point;
  light.color = glm::vec3(1.0f, 0.85f, 0.6f);
  light.intensity = 4.0f;
  const std::array<glm::vec3, 6> path = {glm::vec3(2.0f, 1.6f, 2.0f),  glm::vec3(2.4f, 1.6f, 6.8f),
                                         glm::vec3(6.0f, 1.6f, 6.8f),  glm::vec3(6.0f, 1.6f, 1.5f),
                                         glm::vec3(10.0f, 1.6f, 1.5f), glm::vec3(10.0f, 1.6f, 6.5f)};
  const Entity lantern = b.node("lantern", at(path[0]));
  world.add<Light>(lantern, light);
  AnimationClip clip;
  clip.name = "patrol";
  clip.duration = 12.0f;
  clip.targets = {lantern};
  AnimationChannel channel;
  channel.path = AnimationChannel::Path::Translation;
  for (int k = 0; k <= 10; ++k) {  // out along the path and back: 0 1 2 3 4 5 4 3 2 1 0
    const std::size_t i = static_cast<std::size_t>(k <= 5 ? k : 10 - k);
    channel.times.push_back(1.2f * static_cast<float>(k));
    channel.values.push_back(glm::vec4(path[i], 0.0f));
  }
  clip.channels.push_back(std::move(channel));
  auto clips = std::make_shared<std::vector<AnimationClip>>();
  clips->push_back(std::move(clip));
  Animator animator;
  animator.clips = std::move(clips);
  world.add<Animator>(lantern, std::move(animator));

  Camera camera;
  camera.yfov = 1.1f;
  camera.znear = 0.05f;
  camera.zfar = 50.0f;
  const glm::vec3 eye(0.6f, 1.7f, 0.6f), target(7.0f, 1.0f, 5.0f);
  b.camera(at(eye, glm::quatLookAt(glm::normalize(target - eye), glm::vec3(0, 1, 0))), camera);
  return b.finish();
}

// Humanoid: the production-style character alone, as a character export is.
LoadedScene build_humanoid(World& world) {
  SceneBuilder b(world, "humanoid");
  const Entity character = add_builtin_humanoid(world, b.root(), Transform{});
  // Its two meshes (body, gear) are the armature's children that have one.
  for (Entity armature : world.get<Children>(character).entities)
    for (Entity e : world.get<Children>(armature).entities)
      if (const Mesh* m = world.try_get<Mesh>(e)) b.count_mesh(m->data->triangle_count());
  return b.finish();
}

}  // namespace

std::vector<std::string> builtin_scene_names() { return {"cornell", "courtyard", "furnace", "maze", "humanoid"}; }

Result<LoadedScene> load_builtin(World& world, std::string_view name) {
  if (name == "cornell") return build_cornell(world);
  if (name == "courtyard") return build_courtyard(world);
  if (name == "furnace") return build_furnace(world);
  if (name == "maze") return build_maze(world);
  if (name == "humanoid") return build_humanoid(world);
  std::string valid;
  for (const std::string& n : builtin_scene_names()) valid += (valid.empty() ? "" : ", ") + n;
  return make_error(ErrorCode::NotFound,
                    "builtin:" + std::string(name) + ": no such built-in scene; valid names: " + valid);
}

}  // namespace penumbra
