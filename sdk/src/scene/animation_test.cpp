#include "penumbra/scene/animation.h"

#include <cmath>
#include <memory>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "penumbra/ecs/transform.h"

namespace penumbra {
namespace {

using Interp = AnimationChannel::Interpolation;
using Path = AnimationChannel::Path;

AnimationChannel channel(Path path, Interp interp, std::vector<float> times, std::vector<glm::vec4> values) {
  AnimationChannel c;
  c.path = path;
  c.interpolation = interp;
  c.times = std::move(times);
  c.values = std::move(values);
  return c;
}

glm::vec4 xyzw(glm::quat q) { return {q.x, q.y, q.z, q.w}; }

void expect_vec4_near(glm::vec4 a, glm::vec4 b, float tol) {
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(a[i], b[i], tol) << "component " << i;
}

TEST(AnimationSampling, LinearTranslationAndClampOutsideTheKeys) {
  const auto c = channel(Path::Translation, Interp::Linear, {1.0f, 3.0f}, {{0, 0, 0, 0}, {2, 4, 6, 0}});
  expect_vec4_near(sample_channel(c, 1.5f), {0.5f, 1.0f, 1.5f, 0}, 1e-6f);
  expect_vec4_near(sample_channel(c, 0.0f), {0, 0, 0, 0}, 0.0f);   // before the first key
  expect_vec4_near(sample_channel(c, 9.0f), {2, 4, 6, 0}, 0.0f);   // after the last key
  expect_vec4_near(sample_channel(c, 3.0f), {2, 4, 6, 0}, 0.0f);
}

TEST(AnimationSampling, StepHoldsTheEarlierKey) {
  const auto c = channel(Path::Scale, Interp::Step, {0.0f, 1.0f, 2.0f}, {{1, 1, 1, 0}, {2, 2, 2, 0}, {3, 3, 3, 0}});
  expect_vec4_near(sample_channel(c, 0.999f), {1, 1, 1, 0}, 0.0f);
  expect_vec4_near(sample_channel(c, 1.0f), {2, 2, 2, 0}, 0.0f);
  expect_vec4_near(sample_channel(c, 1.7f), {2, 2, 2, 0}, 0.0f);
}

TEST(AnimationSampling, LinearRotationIsSlerpOnTheShortPath) {
  const glm::vec4 identity(0, 0, 0, 1);
  const glm::vec4 quarter = xyzw(glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 1, 0)));
  // Halfway between 0 and 90 degrees about Y is 45 degrees: (0, sin 22.5, 0, cos 22.5).
  const glm::vec4 expected(0, std::sin(glm::radians(22.5f)), 0, std::cos(glm::radians(22.5f)));
  expect_vec4_near(sample_channel(channel(Path::Rotation, Interp::Linear, {0, 1}, {identity, quarter}), 0.5f),
                   expected, 1e-6f);
  // At a quarter: 22.5 degrees (slerp has constant angular speed; lerp would not).
  const glm::vec4 q1 = sample_channel(channel(Path::Rotation, Interp::Linear, {0, 1}, {identity, quarter}), 0.25f);
  EXPECT_NEAR(2.0f * std::acos(q1.w), glm::radians(22.5f), 1e-5f);
  // -q is the same rotation: slerp must take the short way and give the same result up to sign.
  const glm::vec4 flipped =
      sample_channel(channel(Path::Rotation, Interp::Linear, {0, 1}, {identity, -quarter}), 0.5f);
  EXPECT_NEAR(std::abs(glm::dot(flipped, expected)), 1.0f, 1e-6f);
}

TEST(AnimationSampling, CubicSplineHermiteHandComputed) {
  // Keys at t = 0 and 2 (td = 2): v0 = 1 with out-tangent 1/s, v1 = 3 with in-tangent 0.
  // At s = 0.5: h00 = 0.5, h10 = 0.125, h01 = 0.5, h11 = -0.125;
  // p = 0.5 * 1 + 0.125 * (2 * 1) + 0.5 * 3 + (-0.125) * (2 * 0) = 2.25.
  const auto c = channel(Path::Translation, Interp::CubicSpline, {0.0f, 2.0f},
                         {{9, 9, 9, 0}, {1, 0, 0, 0}, {1, 0, 0, 0},    // key 0: in, value, out
                          {0, 0, 0, 0}, {3, 0, 0, 0}, {9, 9, 9, 0}});  // key 1: in, value, out
  EXPECT_NEAR(sample_channel(c, 1.0f).x, 2.25f, 1e-6f);
  EXPECT_NEAR(sample_channel(c, 0.0f).x, 1.0f, 0.0f);
  EXPECT_NEAR(sample_channel(c, 2.0f).x, 3.0f, 0.0f);
  // s = 0.25: h00 = 0.84375, h10 = 0.140625, h01 = 0.15625 -> 0.84375 + 0.28125 + 0.46875 = 1.59375.
  EXPECT_NEAR(sample_channel(c, 0.5f).x, 1.59375f, 1e-6f);
}

TEST(AnimationSampling, CubicSplineWithSlopeTangentsIsLinear) {
  // Tangents equal to the secant slope make the Hermite curve the straight line.
  const glm::vec4 a(1, 2, 3, 0), b(3, -2, 5, 0), slope = (b - a) / 4.0f;
  const auto c = channel(Path::Translation, Interp::CubicSpline, {1.0f, 5.0f}, {slope, a, slope, slope, b, slope});
  for (float t : {1.5f, 2.0f, 3.3f, 4.9f}) expect_vec4_near(sample_channel(c, t), a + (b - a) * (t - 1.0f) / 4.0f, 1e-5f);
}

TEST(AnimationSampling, CubicSplineRotationsAreNormalised) {
  const glm::vec4 q0(0, 0, 0, 1), q1 = xyzw(glm::angleAxis(1.0f, glm::normalize(glm::vec3(1, 1, 0))));
  const auto c = channel(Path::Rotation, Interp::CubicSpline, {0.0f, 1.0f},
                         {{0, 0, 0, 0}, q0, {0.3f, 0, 0, 0}, {0, 0.2f, 0, 0}, q1, {0, 0, 0, 0}});
  for (float t : {0.1f, 0.5f, 0.8f}) EXPECT_NEAR(glm::length(sample_channel(c, t)), 1.0f, 1e-6f);
}

TEST(AnimationSampling, ClipTimeLoopsOrClamps) {
  EXPECT_FLOAT_EQ(clip_time(2.5f, 1.0f, true), 0.5f);
  EXPECT_FLOAT_EQ(clip_time(-0.25f, 1.0f, true), 0.75f);
  EXPECT_FLOAT_EQ(clip_time(2.5f, 1.0f, false), 1.0f);
  EXPECT_FLOAT_EQ(clip_time(-1.0f, 1.0f, false), 0.0f);
  EXPECT_FLOAT_EQ(clip_time(3.0f, 0.0f, true), 0.0f);
}

// One entity animated by a 2 s clip: x goes 0 -> 4 linearly.
struct AnimatedWorld {
  World world;
  Entity target;
  Entity holder;
  explicit AnimatedWorld(bool loop) {
    register_scene_systems(world);
    target = world.create();
    world.add<Transform>(target);
    AnimationClip clip;
    clip.duration = 2.0f;
    clip.targets = {target};
    clip.channels.push_back(channel(Path::Translation, Interp::Linear, {0.0f, 2.0f}, {{0, 0, 0, 0}, {4, 0, 0, 0}}));
    auto clips = std::make_shared<std::vector<AnimationClip>>();
    clips->push_back(std::move(clip));
    holder = world.create();
    Animator animator;
    animator.clips = clips;
    animator.loop = loop;
    world.add<Animator>(holder, animator);
  }
  float x() { return world.get<Transform>(target).translation.x; }
};

TEST(AnimationSystem, AdvancesAndLoops) {
  AnimatedWorld w(/*loop=*/true);
  w.world.update(0.5);
  EXPECT_NEAR(w.x(), 1.0f, 1e-6f);
  EXPECT_NEAR(w.world.get<WorldTransform>(w.target).matrix[3].x, 1.0f, 1e-6f);  // transforms ran after
  w.world.update(2.0);  // 2.5 s wraps to 0.5 s
  EXPECT_NEAR(w.x(), 1.0f, 1e-5f);
  w.world.get<Animator>(w.holder).speed = 2.0f;
  w.world.update(0.25);  // +0.5 s of clip time
  EXPECT_NEAR(w.x(), 2.0f, 1e-5f);
}

TEST(AnimationSystem, ClampedClipStopsAtItsEnd) {
  AnimatedWorld w(/*loop=*/false);
  w.world.update(1.5);
  EXPECT_TRUE(w.world.get<Animator>(w.holder).playing);
  w.world.update(1.5);
  EXPECT_NEAR(w.x(), 4.0f, 0.0f);
  EXPECT_FALSE(w.world.get<Animator>(w.holder).playing);
  w.world.update(1.0);
  EXPECT_NEAR(w.world.get<Animator>(w.holder).time, 2.0f, 0.0f);
}

// Two bones under a moved parent: bone0 at the origin, bone1 one metre up. Vertices: one on each
// bone and one weighted half and half.
TEST(Skinning, TwoBoneMeshClosedForm) {
  World world;
  register_scene_systems(world);
  const Entity rig = world.create();
  Transform rig_transform;
  rig_transform.translation = {5, 0, 0};  // cancels: skinning outputs the mesh's local frame
  world.add<Transform>(rig, rig_transform);
  const Entity bone0 = world.create(), bone1 = world.create(), body = world.create();
  world.add<Transform>(bone0);
  Transform t1;
  t1.translation = {0, 1, 0};
  world.add<Transform>(bone1, t1);
  world.add<Transform>(body);
  set_parent(world, bone0, rig);
  set_parent(world, bone1, bone0);
  set_parent(world, body, rig);

  auto mesh = std::make_shared<MeshData>();
  mesh->positions = {{0, 0.5f, 0}, {0, 2, 0}, {0, 1.5f, 0}};
  mesh->normals = {{1, 0, 0}, {1, 0, 0}, {1, 0, 0}};
  mesh->joints = {{0, 1, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}};
  mesh->weights = {{1, 0, 0, 0}, {1, 0, 0, 0}, {0.5f, 0.5f, 0, 0}};
  mesh->indices = {0, 1, 2};
  Skin skin;
  skin.joints = {bone0, bone1};
  glm::mat4 ibm1(1.0f);
  ibm1[3] = glm::vec4(0, -1, 0, 1);
  skin.inverse_bind = {glm::mat4(1.0f), ibm1};
  world.add<Skin>(body, skin);
  world.add<Mesh>(body, Mesh{mesh});

  // Bind pose: skinning is the identity.
  world.update(0.0);
  std::vector<glm::vec3> posed;
  skin_positions(*mesh, world.get<SkinPose>(body), posed);
  for (std::size_t i = 0; i < posed.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(posed[i][c], mesh->positions[i][c], 1e-6f);

  // Bend bone1 by 90 degrees about +Z: (0, 1, 0) relative to it turns to (-1, 0, 0).
  world.patch<Transform>(bone1).rotation = glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 0, 1));
  world.update(0.0);
  const SkinPose& pose = world.get<SkinPose>(body);
  skin_positions(*mesh, pose, posed);
  const std::vector<glm::vec3> expected = {{0, 0.5f, 0}, {-1, 1, 0}, {-0.25f, 1.25f, 0}};
  for (std::size_t i = 0; i < posed.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(posed[i][c], expected[i][c], 1e-6f) << "vertex " << i;
  std::vector<glm::vec3> normals;
  skin_normals(*mesh, pose, normals);
  EXPECT_NEAR(glm::dot(normals[0], glm::vec3(1, 0, 0)), 1.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(normals[1], glm::vec3(0, 1, 0)), 1.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(normals[2], glm::normalize(glm::vec3(1, 1, 0))), 1.0f, 1e-6f);
}

// A character as the common pipelines export it: an armature node scaled by 0.01 over the joints
// and the skinned mesh, whose inverse bind matrices undo the joints' world transforms. The skinned
// vertices are where the mesh's positions say (metres); the mesh node's world transform, which
// skinning ignores, would shrink its box a hundredfold.
TEST(PosedBounds, ScaledArmatureIsBoundedByItsSkinnedVertices) {
  World world;
  register_scene_systems(world);
  EXPECT_TRUE(posed_bounds(world).empty());
  const Entity armature = world.create(), hips = world.create(), head = world.create(), body = world.create();
  Transform a;
  a.scale = glm::vec3(0.01f);
  world.add<Transform>(armature, a);
  Transform th, tb;
  th.translation = {0, 90, 0};  // centimetres under the armature: 0.9 m
  tb.translation = {0, 70, 0};
  world.add<Transform>(hips, th);
  world.add<Transform>(head, tb);
  world.add<Transform>(body);
  set_parent(world, hips, armature);
  set_parent(world, head, hips);
  set_parent(world, body, armature);
  auto mesh = std::make_shared<MeshData>();
  mesh->positions = {{-0.25f, 0, 0}, {0.25f, 0, 0}, {0, 1.8f, 0.1f}};
  mesh->normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  mesh->joints = {{0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}};
  mesh->weights = {{1, 0, 0, 0}, {1, 0, 0, 0}, {1, 0, 0, 0}};
  mesh->indices = {0, 1, 2};
  mesh->bounds = Aabb{{-0.25f, 0, 0}, {0.25f, 1.8f, 0.1f}};
  world.update(0.0);
  Skin skin;
  skin.joints = {hips, head};
  skin.inverse_bind = {glm::inverse(world.get<WorldTransform>(hips).matrix),
                       glm::inverse(world.get<WorldTransform>(head).matrix)};
  world.add<Skin>(body, skin);
  world.add<Mesh>(body, Mesh{mesh});
  world.update(0.0);

  Aabb b = posed_bounds(world);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(b.min[c], mesh->bounds.min[c], 1e-5f) << "axis " << c;
    EXPECT_NEAR(b.max[c], mesh->bounds.max[c], 1e-5f) << "axis " << c;
  }
  // Head bent 90 degrees about +Z: its vertex, (0, 0.2, 0.1) from the head (at 1.6 m), turns to
  // (-0.2, 1.6, 0.1).
  world.patch<Transform>(head).rotation = glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 0, 1));
  world.update(0.0);
  b = posed_bounds(world);
  EXPECT_NEAR(b.max.y, 1.6f, 1e-4f);
  EXPECT_NEAR(b.min.x, -0.25f, 1e-5f);

  // Without a skin a mesh is its box through the node's transform.
  world.remove<Skin>(body);
  world.remove<SkinPose>(body);
  world.update(0.0);
  b = posed_bounds(world);
  EXPECT_NEAR(b.max.y, 0.018f, 1e-6f);
}

}  // namespace
}  // namespace penumbra
