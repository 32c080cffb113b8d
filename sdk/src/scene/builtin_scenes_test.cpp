#include "penumbra/scene/builtin.h"

#include <cmath>
#include <filesystem>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/components.h"
#include "penumbra/import/gltf.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

double total_area(const MeshData& m, const glm::mat4& world) {
  double s = 0.0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const glm::dvec3 a = glm::vec3(world * glm::vec4(m.positions[m.indices[3 * t]], 1.0f));
    const glm::dvec3 b = glm::vec3(world * glm::vec4(m.positions[m.indices[3 * t + 1]], 1.0f));
    const glm::dvec3 c = glm::vec3(world * glm::vec4(m.positions[m.indices[3 * t + 2]], 1.0f));
    s += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  return s;
}

Entity find(World& world, std::string_view name) {
  Entity found;
  world.each<Name>([&](Entity e, Name& n) { if (n.value == name) found = e; });
  return found;
}

TEST(BuiltinScenes, NamesAndUnknownNameError) {
  EXPECT_EQ(builtin_scene_names(), (std::vector<std::string>{"cornell", "courtyard", "furnace", "maze", "humanoid"}));
  World world;
  auto r = load_scene(world, "builtin:nowhere");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::NotFound);
  EXPECT_NE(r.error().message.find("builtin:nowhere"), std::string::npos);
  EXPECT_NE(r.error().message.find("cornell, courtyard, furnace"), std::string::npos);
}

TEST(BuiltinScenes, EveryMeshIsValidStaticTaggedAndSmall) {
  for (const std::string& name : builtin_scene_names()) {
    World world;
    auto scene = load_scene(world, "builtin:" + name);
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    EXPECT_LT(scene->triangles, 50000u) << name;
    EXPECT_EQ(bool(scene->camera), name != "humanoid") << name;  // a character export has no camera
    std::size_t meshes = 0, triangles = 0;
    world.each<Mesh>([&](Entity e, Mesh& m) {
      ++meshes;
      triangles += m.data->triangle_count();
      EXPECT_TRUE(m.data->validate(name).ok()) << name << ": " << m.data->name;
      EXPECT_TRUE(world.has<Material>(e));
      const bool movable = world.has<Skin>(e) || m.data->name == "crate";
      EXPECT_EQ(world.has<Static>(e), !movable) << name << ": " << m.data->name;
    });
    EXPECT_EQ(meshes, scene->mesh_entities);
    EXPECT_EQ(triangles, scene->triangles);
  }
}

TEST(BuiltinScenes, TheHumanoidIsAProductionShapedRig) {
  World world;
  auto scene = load_builtin(world, "humanoid");
  ASSERT_TRUE(scene.ok());
  update_world_transforms(world);
  update_skin_poses(world);
  const Entity body = find(world, "body"), gear = find(world, "gear");
  ASSERT_TRUE(body && gear);
  const Skin& skin = world.get<Skin>(body);
  EXPECT_EQ(skin.joints.size(), 65u);
  EXPECT_EQ(world.get<Skin>(gear).joints, skin.joints);  // one skeleton, two meshes
  EXPECT_EQ(world.get<Name>(skin.joints.front()).value, "mixamorig:Hips");
  EXPECT_TRUE(find(world, "mixamorig:LeftHandPinky4"));
  // The armature's 0.01 scale: the joint nodes hold centimetres, the skinned character is
  // 1.82 m tall in metres (the head's top at 181 cm, the soles at 0.5 cm).
  EXPECT_FLOAT_EQ(world.get<Transform>(find(world, "mixamorig:Spine")).translation.y, 10.0f);
  const Aabb bounds = posed_bounds(world);
  EXPECT_NEAR(bounds.max.y, 1.81f, 0.005f);
  EXPECT_NEAR(bounds.min.y, 0.0f, 0.01f);
  EXPECT_GT(world.get<Mesh>(body).data->positions.size(), 5000u);
  // The one clip is a single frame: no joint turns more than 0.005 rad.
  const Animator& animator = world.get<Animator>(find(world, "humanoid"));
  ASSERT_EQ(animator.clips->size(), 1u);
  EXPECT_NEAR((*animator.clips)[0].duration, 0.067f, 0.001f);
  for (const AnimationChannel& ch : (*animator.clips)[0].channels)
    for (const glm::vec4& q : ch.values)
      EXPECT_LT(2.0f * std::acos(std::min(1.0f, std::abs(q.w))), 0.0051f) << ch.target;
  // Its walk, delivered apart: a second clip that swings the thighs +-0.45 rad and bends the knees.
  const Entity humanoid = find(world, "humanoid");
  ASSERT_TRUE(add_builtin_humanoid_walk(world, humanoid));
  const Animator& walking = world.get<Animator>(humanoid);
  ASSERT_EQ(walking.clips->size(), 2u);
  const AnimationClip& walk = (*walking.clips)[1];
  EXPECT_EQ(walk.name, "Walk");
  float thigh = 0.0f, knee = 0.0f;
  for (const AnimationChannel& ch : walk.channels) {
    const std::string& joint = world.get<Name>(walk.targets[ch.target]).value;
    for (const glm::vec4& q : ch.values) {
      const float angle = 2.0f * std::acos(std::min(1.0f, std::abs(q.w)));
      if (joint == "mixamorig:LeftUpLeg") thigh = std::max(thigh, angle);
      if (joint == "mixamorig:LeftLeg") knee = std::max(knee, angle);
    }
  }
  EXPECT_NEAR(thigh, 0.45f, 0.01f);      // a key at the swing's peak
  EXPECT_GT(knee, 0.55f);                  // the keys straddle the bend's peak of 0.65
  EXPECT_LT(knee, 0.651f);
  World empty;
  EXPECT_FALSE(add_builtin_humanoid_walk(empty, empty.create()));  // no Animator: nothing added
}

TEST(BuiltinScenes, CornellBoxMatchesThePublishedData) {
  World world;
  auto scene = load_builtin(world, "cornell");
  ASSERT_TRUE(scene.ok());
  update_world_transforms(world);
  // Floor: the published quad (552.8, 0) (0, 0) (0, 559.2) (549.6, 559.2) mm has area
  // 0.5 * |d1 x d2| with diagonals d1 = (-3.2, 559.2)... computed exactly by the shoelace formula.
  const double floor_area = 0.5 * std::abs(0.5528 * 0.0 - 0.0 * 0.0 + 0.0 * 0.5592 - 0.0 * 0.0 +
                                           0.0 * 0.5592 - 0.5496 * 0.5592 + 0.5496 * 0.0 - 0.5528 * 0.5592);
  const Entity floor = find(world, "floor");
  ASSERT_TRUE(floor);
  EXPECT_NEAR(total_area(*world.get<Mesh>(floor).data, glm::mat4(1.0f)), floor_area, 1e-6);
  // Every wall faces the room's interior; the blocks face out of themselves.
  const glm::vec3 centre(0.278f, 0.274f, 0.280f);
  for (const char* wall : {"floor", "ceiling", "back_wall", "red_wall", "green_wall"}) {
    const MeshData& m = *world.get<Mesh>(find(world, wall)).data;
    for (std::size_t i = 0; i < m.positions.size(); ++i)
      EXPECT_GT(glm::dot(m.normals[i], centre - m.positions[i]), 0.0f) << wall;
  }
  // Reflectances: red wall red, green wall green.
  const glm::vec4 red = world.get<Material>(find(world, "red_wall")).base_color;
  const glm::vec4 green = world.get<Material>(find(world, "green_wall")).base_color;
  EXPECT_GT(red.r, 5 * red.g);
  EXPECT_GT(green.g, 2 * green.r);
  // The light: 130 x 105 mm rect just under the ceiling, facing down (local -Z -> world -Y).
  const Entity light = find(world, "light");
  const Light& l = world.get<Light>(light);
  EXPECT_EQ(l.type, Light::Type::Rect);
  EXPECT_NEAR(l.size.x * l.size.y, 0.130f * 0.105f, 1e-7f);
  const glm::mat4& lw = world.get<WorldTransform>(light).matrix;
  const glm::vec3 facing = -glm::vec3(lw[2]);
  EXPECT_NEAR(facing.y, -1.0f, 1e-6f);
  EXPECT_LT(lw[3].y, 0.5488f);
  EXPECT_GT(lw[3].y, 0.54f);
  // Camera at (278, 273, -800) mm looking +Z into the open front.
  const glm::mat4& cw = world.get<WorldTransform>(scene->camera).matrix;
  EXPECT_NEAR(cw[3].z, -0.8f, 1e-6f);
  EXPECT_NEAR(-cw[2].z, 1.0f, 1e-6f);
}

TEST(BuiltinScenes, FurnaceIsAClosedInwardSphere) {
  World world;
  auto scene = load_builtin(world, "furnace");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene->mesh_entities, 1u);
  EXPECT_FLOAT_EQ(kFurnaceIrradiance, 2.0f * 3.14159265f);
  world.each<Mesh>([&](Entity e, Mesh& m) {
    const Material& mat = world.get<Material>(e);
    EXPECT_EQ(glm::vec3(mat.base_color), glm::vec3(kFurnaceAlbedo));
    EXPECT_EQ(mat.emissive, glm::vec3(kFurnaceRadiance));
    // Inward: normals point at the centre, and the signed volume is negative.
    double volume = 0.0;
    for (std::size_t t = 0; t < m.data->triangle_count(); ++t) {
      const glm::dvec3 a = m.data->positions[m.data->indices[3 * t]], b = m.data->positions[m.data->indices[3 * t + 1]],
                       c = m.data->positions[m.data->indices[3 * t + 2]];
      volume += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    EXPECT_NEAR(volume, -4.0 / 3.0 * 3.14159265358979 * kFurnaceRadius, 0.02);
    for (std::size_t i = 0; i < m.data->positions.size(); ++i)
      EXPECT_LT(glm::dot(m.data->normals[i], m.data->positions[i]), 0.0f);
  });
}

TEST(BuiltinScenes, CourtyardHasThinWallCratesLightsAndAWalkingCharacter) {
  World world;
  register_scene_systems(world);
  auto scene = load_builtin(world, "courtyard");
  ASSERT_TRUE(scene.ok());
  const Entity thin = find(world, "thin_wall");
  ASSERT_TRUE(thin);
  const Aabb wall = world.get<Mesh>(thin).data->bounds;
  EXPECT_NEAR(wall.extent().z, 0.05f, 1e-6f);
  std::size_t crates = 0, directional = 0, point = 0;
  world.each<Mesh>([&](Entity, Mesh& m) { crates += m.data->name == "crate"; });
  world.each<Light>([&](Entity, Light& l) {
    directional += l.type == Light::Type::Directional;
    point += l.type == Light::Type::Point;
  });
  EXPECT_GE(crates, 3u);
  EXPECT_EQ(directional, 1u);
  EXPECT_EQ(point, 1u);

  // The character: skinned, weights normalised, and walking changes its pose.
  Entity body;
  world.each<Skin>([&](Entity e, Skin&) { body = e; });
  ASSERT_TRUE(body);
  const MeshData& mesh = *world.get<Mesh>(body).data;
  for (const glm::vec4& w : mesh.weights) EXPECT_NEAR(w.x + w.y + w.z + w.w, 1.0f, 1e-6f);
  world.update(0.0);
  std::vector<glm::vec3> bind, walking, looped;
  skin_positions(mesh, world.get<SkinPose>(body), bind);
  // t = 0: a standing figure about 1.8 m tall whose feet touch the ground (knees bent 0.3 rad).
  Aabb standing;
  for (const glm::vec3& p : bind) standing.extend(p);
  EXPECT_NEAR(standing.min.y, 0.0f, 0.1f);
  EXPECT_NEAR(standing.max.y, 1.83f, 0.05f);
  world.update(0.25);
  skin_positions(mesh, world.get<SkinPose>(body), walking);
  float stride = 0.0f;
  for (std::size_t i = 0; i < bind.size(); ++i) stride = std::max(stride, glm::distance(bind[i], walking[i]));
  EXPECT_GT(stride, 0.2f);
  world.update(1.0);  // one full cycle later: the same pose (looping clip)
  skin_positions(mesh, world.get<SkinPose>(body), looped);
  for (std::size_t i = 0; i < bind.size(); ++i) EXPECT_LT(glm::distance(walking[i], looped[i]), 1e-4f);
}

TEST(BuiltinScenes, LoadSceneImportsGltfPaths) {
  World world;
  const std::string path = std::string(checkout::kSourceDir) + "/tests/data/gltf/valid.gltf";
  auto scene = load_scene(world, path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->name, "valid.gltf");
  EXPECT_EQ(scene->mesh_entities, 2u);
  EXPECT_TRUE(scene->camera);
  auto missing = load_scene(world, "/nonexistent/scene.glb");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
}

}  // namespace
}  // namespace penumbra
