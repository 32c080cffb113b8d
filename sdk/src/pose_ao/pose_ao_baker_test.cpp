// The pose-AO bake on the courtyard's skinned walker (8 joints, ~800 vertices): the rig against the
// animation system, ranges, determinism at 1 and 2 threads, the extremes of issue 7 (a joint that
// never moves, fewer poses than coefficients, far poses, weightless vertices, scale 1e-3 and 1e4),
// the model against its baselines, bake_world + attach + the system over the walk cycle.
#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <filesystem>
#include <string>

#include "penumbra/scene/entity_key.h"
#include "penumbra/import/gltf.h"
#include "penumbra/runtime.h"
#include "penumbra/bake/baker.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/pose_ao/joint_roles.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

struct Walker {
  std::unique_ptr<World> world = std::make_unique<World>();
  Entity mesh;
  Walker() {
    EXPECT_TRUE(load_builtin(*world, "courtyard"));
    update_world_transforms(*world);
    update_skin_poses(*world);
    world->view<Skin, Mesh>().each([&](Entity e, Skin&, Mesh&) { mesh = e; });
  }
  const MeshData& data() { return *world->get<Mesh>(mesh).data; }
};

// Quick settings: a few poses and rays (the bench measures quality).
SkinnedPoseAO quick() {
  SkinnedPoseAO s;
  s.reference_poses = 40;
  s.clip_poses = 4;
  s.rays_per_vertex = 16;
  s.locality = 2;
  return s;
}

void expect_near_matrix(const glm::mat4& a, const glm::mat4& b, float tol) {
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(a[c][k], b[c][k], tol) << c << "," << k;
}

TEST(PoseAORig, MatchesTheAnimationSystem) {
  Walker w;
  ASSERT_TRUE(w.mesh);
  auto rig = make_pose_rig(*w.world, w.mesh, "walker");
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_EQ(rig->joint_count(), 8u);
  EXPECT_EQ(rig->parents[0], -1);  // hips
  EXPECT_EQ(rig->parents[3], 2);   // left shin under left thigh
  ASSERT_EQ(rig->clips.size(), 1u);
  // The bind pose skins to the identity.
  for (const glm::mat4& m : skinning_matrices(*rig, rig->bind)) expect_near_matrix(m, glm::mat4(1.0f), 1e-5f);
  // A clip frame gives what the animation and skinning systems give.
  for (float t : {0.1f, 0.37f, 0.8f}) {
    const AnimationClip& clip = *rig->clips[0];
    apply_clip(*w.world, clip, t);
    update_world_transforms(*w.world);
    update_skin_poses(*w.world);
    const std::vector<glm::mat4> mine = skinning_matrices(*rig, clip_pose(*rig, 0, t));
    const SkinPose& pose = w.world->get<SkinPose>(w.mesh);
    for (std::size_t j = 0; j < 8; ++j) expect_near_matrix(mine[j], pose.joint_matrices[j], 1e-5f);
  }
  // Ranges: the limbs swing about X; hips and spine never rotate.
  EXPECT_FALSE(rig->animated[0]);
  EXPECT_FALSE(rig->animated[1]);
  for (std::size_t j = 2; j < 8; ++j) {
    EXPECT_TRUE(rig->animated[j]) << j;
    EXPECT_GT(rig->clip_ranges[j].max.x - rig->clip_ranges[j].min.x, 0.5f) << j;
    EXPECT_NEAR(rig->clip_ranges[j].max.y, 0.0f, 1e-5f);
  }
  const std::vector<JointRange> ranges = pose_space(*rig, quick()).ranges;
  EXPECT_NEAR(ranges[2].max.x - ranges[2].min.x, 1.5f * (rig->clip_ranges[2].max.x - rig->clip_ranges[2].min.x), 1e-5f);
  EXPECT_EQ(ranges[0].max, glm::vec3(0.0f));
}

// The shared CesiumMan.glb ("" when the shared assets are not checked out).
std::string cesium_man_path() {
  const std::string path = std::string(checkout::kSharedDir) + "/assets/CesiumMan.glb";
  return std::filesystem::exists(path) ? path : std::string();
}

// Loads `path` into `world`, transforms and skin poses updated; its (last) skinned mesh, null on
// failure.
Entity load_skinned(World& world, const std::string& path) {
  if (!load_scene(world, path)) return Entity{};
  update_world_transforms(world);
  update_skin_poses(world);
  Entity mesh;
  world.view<Skin, Mesh>().each([&](Entity e, Skin&, Mesh&) { mesh = e; });
  return mesh;
}

TEST(PoseAORig, CesiumManMatchesTheAnimationSystem) {
  const std::string path = cesium_man_path();
  if (path.empty()) GTEST_SKIP() << "CesiumMan.glb not found (the shared assets are not checked out)";
  World world;
  const Entity mesh = load_skinned(world, path);
  ASSERT_TRUE(mesh);
  auto rig = make_pose_rig(world, mesh, "CesiumMan");
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(rig->joint_count(), 19u);
  ASSERT_EQ(rig->clips.size(), 1u);
  for (const glm::mat4& m : skinning_matrices(*rig, rig->bind)) expect_near_matrix(m, glm::mat4(1.0f), 1e-4f);
  const AnimationClip& clip = *rig->clips[0];
  for (float t : {0.2f, 0.9f * clip.duration}) {
    apply_clip(world, clip, t);
    update_world_transforms(world);
    update_skin_poses(world);
    const std::vector<glm::mat4> mine = skinning_matrices(*rig, clip_pose(*rig, 0, t));
    for (std::size_t j = 0; j < mine.size(); ++j)
      expect_near_matrix(mine[j], world.get<SkinPose>(mesh).joint_matrices[j], 1e-4f);
  }
  std::size_t animated = 0;
  for (bool a : rig->animated) animated += a ? 1 : 0;
  EXPECT_GT(animated, 10u);
}

// CesiumMan's joints are named per limb ("leg_joint_L_1" .. "_5", "Skeleton_arm_joint_L__4_" ..
// "__2_"): each limb's chain takes its parts in order, and its pose space by role places the parts'
// motions on their bones.
TEST(PoseAORig, CesiumMansLimbChainsTakeTheirPartsInOrder) {
  const std::string path = cesium_man_path();
  if (path.empty()) GTEST_SKIP() << "CesiumMan.glb not found (the shared assets are not checked out)";
  World world;
  const Entity mesh = load_skinned(world, path);
  ASSERT_TRUE(mesh);
  auto rig = make_pose_rig(world, mesh, "CesiumMan").value();
  std::vector<JointRole> roles;
  for (const std::string& n : rig.names) roles.push_back(joint_role(n));
  assign_chain_roles(rig.parents, roles);
  const auto role_of = [&](std::string_view name) {
    for (std::size_t j = 0; j < rig.joint_count(); ++j)
      if (rig.names[j] == name) return roles[j];
    ADD_FAILURE() << name;
    return JointRole::Unknown;
  };
  EXPECT_EQ(role_of("leg_joint_L_1"), JointRole::Thigh);
  EXPECT_EQ(role_of("leg_joint_R_2"), JointRole::Calf);
  EXPECT_EQ(role_of("leg_joint_L_3"), JointRole::Foot);
  EXPECT_EQ(role_of("leg_joint_R_5"), JointRole::Toe);
  EXPECT_EQ(role_of("Skeleton_arm_joint_L__4_"), JointRole::UpperArm);
  EXPECT_EQ(role_of("Skeleton_arm_joint_R__2_"), JointRole::Forearm);
  EXPECT_EQ(role_of("Skeleton_arm_joint_L__2_"), JointRole::Hand);
  EXPECT_EQ(role_of("Skeleton_neck_joint_1"), JointRole::Neck);
  SkinnedPoseAO s;
  s.pose_source = SkinnedPoseAO::PoseSource::Roles;
  const PoseSpace space = pose_space(rig, s);
  EXPECT_EQ(space.source, PoseSpace::Source::Roles);
  EXPECT_EQ(space.roles, 19u);
  // Placed on their bones: all but the hips (no motion); the forearms, hands, the root's spine
  // joint and the left thigh, whose bind frames lie more than 37 degrees off their bones, in axes
  // of their own. Each knee bends one way, 1.4 rad.
  EXPECT_EQ(space.anatomical, 18u);
  for (const char* knee : {"leg_joint_L_2", "leg_joint_R_2"}) {
    std::size_t j = 0;
    while (rig.names[j] != knee) ++j;
    int one_way = 0;
    for (int a = 0; a < 3; ++a) {
      const float lo = space.ranges[j].min[a], hi = space.ranges[j].max[a];
      one_way += (lo == 0.0f && hi == 1.4f) || (lo == -1.4f && hi == 0.0f);
    }
    EXPECT_EQ(one_way, 1) << knee;
  }
}

TEST(PoseAOBake, BitIdenticalAtOneAndTwoThreads) {
  Walker w;
  const SkinnedPoseAO s = quick();
  std::vector<std::vector<std::byte>> payloads;
  for (unsigned threads : {1u, 2u}) {
    ThreadPool pool(threads);
    JobContext jobs(&pool);
    MemoryBudget budget;
    auto data = bake_pose_ao(*w.world, w.mesh, s, 3, jobs, budget);
    ASSERT_TRUE(data) << data.error().message;
    payloads.push_back(write_pose_ao_chunk(*data).payload);
  }
  EXPECT_EQ(payloads[0], payloads[1]);
}

// Held-out AO error of the model and of the two baselines, over random poses of a different seed.
struct HeldOut {
  double linear = 0, bind = 0, mean = 0;
};
HeldOut held_out(Walker& w, const PoseAOData& data, const SkinnedPoseAO& s, std::size_t poses) {
  auto rig = make_pose_rig(*w.world, w.mesh, "walker").value();
  auto tracer = PoseAOTracer::create(w.world->get<Mesh>(w.mesh).data, rig.joint_count(), "walker").value();
  const std::vector<JointRange> ranges = pose_space(rig, s).ranges;
  JobContext jobs;
  HeldOut e;
  const std::size_t n = data.vertex_count;
  std::vector<float> ref(n), model(n), f;
  for (std::size_t p = 0; p < poses; ++p) {
    const std::vector<glm::mat4> m = skinning_matrices(rig, random_pose(rig, ranges, 777, p));
    EXPECT_TRUE(tracer.trace(m, 64, 99, jobs, ref));
    pose_features(rig.parents, m, f);
    evaluate_pose_ao(data, f, model);
    for (std::size_t v = 0; v < n; ++v) {
      e.linear += std::pow(model[v] - ref[v], 2.0);
      e.bind += std::pow(data.bind_ao[v] - ref[v], 2.0);
      e.mean += std::pow(data.mean_ao[v] - ref[v], 2.0);
    }
  }
  const double count = static_cast<double>(poses * n);
  e.linear = std::sqrt(e.linear / count);
  e.bind = std::sqrt(e.bind / count);
  e.mean = std::sqrt(e.mean / count);
  return e;
}

TEST(PoseAOBake, BeatsBothBaselinesOnHeldOutPoses) {
  Walker w;
  SkinnedPoseAO s = quick();
  s.reference_poses = 80;
  s.rays_per_vertex = 32;
  JobContext jobs;
  MemoryBudget budget;
  auto data = bake_pose_ao(*w.world, w.mesh, s, 1, jobs, budget);
  ASSERT_TRUE(data) << data.error().message;
  EXPECT_EQ(data->poses, 84u);
  const HeldOut e = held_out(w, *data, s, 8);
  EXPECT_LT(e.linear, std::min(e.bind, e.mean)) << e.linear << " " << e.bind << " " << e.mean;
}

TEST(PoseAOExtremes, AJointThatNeverMovesDoesNotBlowUp) {
  Walker w;
  SkinnedPoseAO s = quick();
  s.lambda = 0.0f;  // no regularisation to hide behind
  s.locality = 4;
  s.clip_poses = 0;
  s.joint_ranges.assign(8, JointRange{glm::vec3(-0.4f), glm::vec3(0.4f)});
  s.joint_ranges[6] = JointRange{};  // the left arm never moves
  JobContext jobs;
  MemoryBudget budget;
  auto data = bake_pose_ao(*w.world, w.mesh, s, 5, jobs, budget);
  ASSERT_TRUE(data) << data.error().message;
  for (const PoseAOGroup& g : data->groups)
    for (std::uint32_t k = 0; k < g.joint_count; ++k) EXPECT_NE(g.joints[k], 6u);
  for (std::uint16_t h : data->coefficients) {
    const float c = glm::unpackHalf1x16(h);
    EXPECT_TRUE(std::isfinite(c) && std::abs(c) < 100.0f) << c;
  }
  EXPECT_LT(data->training_rmse, 0.1f);
  // Far outside the training range (every joint turned by 2.5 rad): AO stays in [0, 1].
  auto rig = make_pose_rig(*w.world, w.mesh, "walker").value();
  std::vector<JointRange> far(8, JointRange{glm::vec3(2.5f), glm::vec3(2.5f)});
  std::vector<float> f, ao(data->vertex_count);
  pose_features(rig.parents, skinning_matrices(rig, random_pose(rig, far, 1, 0)), f);
  evaluate_pose_ao(*data, f, ao);
  for (float a : ao) EXPECT_TRUE(a >= 0.0f && a <= 1.0f) << a;
}

TEST(PoseAOExtremes, FewerPosesThanCoefficientsWarnsAndStillFits) {
  Walker w;
  SkinnedPoseAO s = quick();
  s.reference_poses = 12;
  s.clip_poses = 0;
  s.locality = 4;
  JobContext jobs;
  MemoryBudget budget;
  std::vector<std::string> warnings;
  auto data = bake_pose_ao(*w.world, w.mesh, s, 2, jobs, budget, &warnings);
  ASSERT_TRUE(data) << data.error().message;
  EXPECT_EQ(data->locality, 1u);  // 1 + 9 x 1 <= 12 poses
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("locality reduced"), std::string::npos);
  for (std::uint16_t h : data->coefficients) EXPECT_TRUE(std::isfinite(glm::unpackHalf1x16(h)));
  const auto lines = describe_pose_ao_chunk(write_pose_ao_chunk(*data));
  EXPECT_NE(lines.back().find("warning"), std::string::npos);
}

// As some exports hold a pose: every clip shortened to two equal keys 0.067 s apart.
void hold_first_key(World& world) {
  world.view<Animator>().each([](Entity, Animator& a) {
    auto clips = std::make_shared<std::vector<AnimationClip>>(*a.clips);
    for (AnimationClip& c : *clips) {
      c.duration = 0.067f;
      for (AnimationChannel& ch : c.channels) {
        const glm::vec4 v = ch.values[ch.interpolation == AnimationChannel::Interpolation::CubicSpline ? 1 : 0];
        ch.interpolation = AnimationChannel::Interpolation::Linear;
        ch.times = {0.0f, 0.067f};
        ch.values = {v, v};
      }
    }
    a.clips = clips;
  });
}

TEST(PoseAOExtremes, ADegeneratePoseSpaceIsWidenedWithAWarningOrRefused) {
  Walker w;
  SkinnedPoseAO s = quick();
  auto walking = make_pose_rig(*w.world, w.mesh, "walker").value();
  const PoseSpace from_clips = pose_space(walking, s);
  EXPECT_EQ(from_clips.source, PoseSpace::Source::Clips);
  EXPECT_GT(from_clips.clip_widest_range, 0.5f);

  hold_first_key(*w.world);
  auto held = make_pose_rig(*w.world, w.mesh, "walker").value();
  // The walker's joint names give their roles ("left_thigh", "right_shin", ...), so by default the
  // degenerate clips give way to the roles' limits.
  const PoseSpace by_role = pose_space(held, s);
  EXPECT_EQ(by_role.source, PoseSpace::Source::DegenerateClipsRoles);
  EXPECT_EQ(by_role.roles, held.joint_count());
  // The spine, thighs, shins and arms get their roles' motions about their bones (the arms, whose
  // bones lie 46 degrees off every axis of their frames, in axes of their own); the hips (no
  // motion) +-its role's limit on each axis.
  EXPECT_EQ(by_role.anatomical, 7u);
  for (std::size_t j = 0; j < held.joint_count(); ++j) {
    const JointRole role = joint_role(held.names[j]);
    const glm::vec3 per_axis(role_limit(role, 0.0f));
    if (role == JointRole::Hips)
      EXPECT_EQ(by_role.ranges[j].max, per_axis) << held.names[j];
    else
      EXPECT_NE(by_role.ranges[j].max, per_axis) << held.names[j];
    const bool own_axes = by_role.ranges[j].axes != glm::quat(1.0f, 0.0f, 0.0f, 0.0f);
    EXPECT_EQ(own_axes, role == JointRole::UpperArm) << held.names[j];
  }
  // Asked for the clips alone: keys that never change rotate no joint, so every joint gets
  // +-default_range.
  s.pose_source = SkinnedPoseAO::PoseSource::Clips;
  const PoseSpace space = pose_space(held, s);
  EXPECT_EQ(space.source, PoseSpace::Source::DegenerateClips);
  EXPECT_LT(space.clip_widest_range, kPoseMinJointRange);
  for (std::size_t j = 0; j < held.joint_count(); ++j) {
    EXPECT_FALSE(held.animated[j]) << j;
    EXPECT_EQ(space.ranges[j].max, glm::vec3(s.default_range)) << j;
  }
  EXPECT_EQ(space.moving, held.joint_count());

  // The bake says so, naming the clip, and trains on the widened space: its random poses differ.
  JobContext jobs;
  MemoryBudget budget;
  std::vector<std::string> warnings;
  s.reference_poses = 24;
  auto data = bake_pose_ao(*w.world, w.mesh, s, 3, jobs, budget, &warnings);
  ASSERT_TRUE(data) << data.error().message;
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("degenerate pose space"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("0.067 s"), std::string::npos) << warnings[0];
  EXPECT_GT(data->locality, 0u);

  // Ranges given by hand that move nothing are refused, naming the field.
  s.joint_ranges.assign(held.joint_count(), JointRange{glm::vec3(-0.001f), glm::vec3(0.001f)});
  auto refused = bake_pose_ao(*w.world, w.mesh, s, 3, jobs, budget);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("joint_ranges turn no joint"), std::string::npos) << refused.error().message;
}

// The production-shaped humanoid (builtin.h): 65 Mixamo-named joints, an armature scaled 0.01,
// body and gear meshes on one skin, a one-frame clip.
struct Humanoid {
  std::unique_ptr<World> world = std::make_unique<World>();
  Entity body, gear;
  Humanoid() {
    EXPECT_TRUE(load_builtin(*world, "humanoid"));
    update_world_transforms(*world);
    update_skin_poses(*world);
    world->each<Name>([&](Entity e, Name& n) {
      if (n.value == "body") body = e;
      if (n.value == "gear") gear = e;
    });
  }
};

TEST(PoseAOProductionRig, AOneFrameClipGivesWayToTheJointsRoles) {
  Humanoid h;
  auto rig = make_pose_rig(*h.world, h.body, "humanoid");
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_EQ(rig->joint_count(), 65u);
  const PoseSpace space = pose_space(*rig, SkinnedPoseAO{});
  EXPECT_EQ(space.source, PoseSpace::Source::DegenerateClipsRoles);
  EXPECT_EQ(space.roles, 65u);
  // End joints stay fixed; the arms and fingers lie along x in the T-pose, so x is their twist.
  const auto range_of = [&](std::string_view name) {
    for (std::size_t j = 0; j < rig->joint_count(); ++j)
      if (rig->names[j] == name) return space.ranges[j].max.x;
    ADD_FAILURE() << name;
    return -1.0f;
  };
  EXPECT_EQ(range_of("mixamorig:HeadTop_End"), 0.0f);
  EXPECT_EQ(range_of("mixamorig:LeftForeArm"), role_motion(JointRole::Forearm)->twist);
  EXPECT_EQ(range_of("mixamorig:RightHandIndex1"), role_motion(JointRole::Finger)->twist);
  // A knuckle curls (about z, towards the palm) and spreads (about y, towards forward); the joints
  // beyond it only curl.
  for (const char* finger : {"mixamorig:RightHandIndex1", "mixamorig:LeftHandRing2", "mixamorig:RightHandPinky3"}) {
    std::size_t j = 0;
    while (rig->names[j] != finger) ++j;
    const bool knuckle = std::string_view(finger).ends_with('1');
    const JointRange& r = space.ranges[j];
    EXPECT_FLOAT_EQ(r.max.z - r.min.z, 1.0f) << finger;
    EXPECT_FLOAT_EQ(r.max.y - r.min.y, knuckle ? 0.3f : 0.0f) << finger;
    EXPECT_FLOAT_EQ(r.max.x - r.min.x, knuckle ? 0.1f : 0.0f) << finger;
  }
  EXPECT_EQ(space.moving, 62u);  // all but the three end joints
  // Every joint of a role with a motion gets it about its bone, all but the hips (no motion); the
  // thumbs, which point 41 degrees off every axis of their frames, in axes of their own.
  EXPECT_EQ(space.anatomical, 62u - 1u);

  // Limits by name go over the roles; a pattern that matches nothing is named in a warning.
  SkinnedPoseAO limited;
  limited.joint_limits = "LeftForeArm=1.5, *Hand*=0, nosuch=0.2";
  ASSERT_TRUE(validate_pose_ao(limited, rig->joint_count(), "humanoid"));
  const PoseSpace by_name = pose_space(*rig, limited);
  EXPECT_EQ(by_name.source, PoseSpace::Source::DegenerateClipsRoles);
  const auto limited_range = [&](std::string_view name) {
    for (std::size_t j = 0; j < rig->joint_count(); ++j)
      if (rig->names[j] == name) return by_name.ranges[j].max.x;
    return -1.0f;
  };
  EXPECT_EQ(limited_range("mixamorig:LeftForeArm"), 1.5f);
  EXPECT_EQ(limited_range("mixamorig:RightHandIndex2"), 0.0f);
  EXPECT_EQ(limited_range("mixamorig:RightForeArm"), role_motion(JointRole::Forearm)->twist);
  EXPECT_EQ(by_name.limited, 1u + 2u * 21u);  // the forearm, both hands and their 20 finger joints each
  EXPECT_EQ(by_name.unmatched_limits, std::vector<std::string>{"nosuch"});
  limited.joint_limits = "Spine=fast";
  auto refused = validate_pose_ao(limited, rig->joint_count(), "humanoid");
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("'Spine=fast'"), std::string::npos) << refused.error().message;
}

// The roles' ranges are placed on each joint's bone in the body's frame (up from the hips to the
// head, left from the right-side joints to the left-side ones; the humanoid faces +Z, its left is
// +X, no joint is rotated in the bind pose): in every random pose the knees bend backward and the
// elbows forward (to 0.01, what a twist and a side swing of a few hundredths give together: the
// range is a box of rotation vectors), a thigh crosses the midline by far less than it can move
// away from it (0.2 rad asked, up to 0.45 with the twist and the flexion), and fingers curl
// towards the palm, which faces down.
TEST(PoseAOProductionRig, TheRolesBendKneesBackwardElbowsForwardAndFingersTowardsThePalm) {
  Humanoid h;
  auto rig = make_pose_rig(*h.world, h.body, "humanoid").value();
  const PoseSpace space = pose_space(rig, SkinnedPoseAO{});
  const auto joint = [&](std::string_view name) {
    for (std::size_t j = 0; j < rig.joint_count(); ++j)
      if (rig.names[j] == "mixamorig:" + std::string(name)) return j;
    ADD_FAILURE() << name;
    return std::size_t{0};
  };
  // The bone of joint j (to its child `child`) turned by the pose's rotation of j.
  const auto tip = [&](const Pose& pose, std::string_view name, std::string_view child) {
    const std::size_t j = joint(name);
    const glm::vec3 bone = glm::normalize(rig.bind_positions[joint(child)] - rig.bind_positions[j]);
    return std::pair{bone, pose[j].rotation * bone};
  };
  int bent_knees = 0, bent_elbows = 0, curled_fingers = 0;
  float most_medial = 0.0f, most_lateral = 0.0f;
  for (std::uint64_t p = 0; p < 200; ++p) {
    const Pose pose = random_pose(rig, space.ranges, 11, p);
    for (const char* side : {"Left", "Right"}) {
      const std::string s = side;
      // The palms face down in the T-pose: a knuckle extends 0.2 rad at most (up), the joints
      // beyond it curl down only and stay in the finger's plane (no spread, no twist).
      for (const char* finger : {"Index", "Middle", "Pinky"}) {
        const std::string f = s + "Hand" + finger;
        const auto [knuckle, knuckle_now] = tip(pose, f + "1", f + "2");
        EXPECT_LE(knuckle_now.y, std::sin(0.2f) + 0.01f) << f << "1, pose " << p;
        for (const char* k : {"2", "3"}) {
          const auto [hinge, hinge_now] = tip(pose, f + k, f + std::to_string(std::stoi(k) + 1));
          EXPECT_LE(hinge_now.y, 0.01f) << f << k << ", pose " << p;
          EXPECT_NEAR(hinge_now.z, hinge.z, 0.01f) << f << k << ", pose " << p;
          curled_fingers += hinge_now.y < -0.3f;
        }
      }
      const auto [shin, shin_now] = tip(pose, s + "Leg", s + "Foot");
      EXPECT_LE(shin_now.z, 0.01f) << side << " knee, pose " << p;  // backward
      bent_knees += shin_now.z < -0.3f;
      const auto [forearm, forearm_now] = tip(pose, s + "ForeArm", s + "Hand");
      EXPECT_GE(forearm_now.z, -0.01f) << side << " elbow, pose " << p;  // forward
      bent_elbows += forearm_now.z > 0.3f;
      const float medial = s == "Left" ? -1.0f : 1.0f;
      const auto [thigh, thigh_now] = tip(pose, s + "UpLeg", s + "Leg");
      EXPECT_LE(medial * thigh_now.x, 0.45f) << side << " hip, pose " << p;
      most_medial = std::max(most_medial, medial * thigh_now.x);
      most_lateral = std::max(most_lateral, -medial * thigh_now.x);
    }
  }
  EXPECT_GT(most_lateral, most_medial + 0.1f);
  // And they do bend: the ranges are not empty.
  EXPECT_GT(bent_knees, 100);
  EXPECT_GT(bent_elbows, 100);
  EXPECT_GT(curled_fingers, 600);  // of 2400 joint-poses

  // A thumb points 41 degrees off its frame's axes, so its range has axes of its own: its knuckle
  // twists about its bone by 0.05 at most, its hinges turn only about bone x up (its palm is not
  // known: the hinge curls +-0.5 both ways).
  const glm::vec3 up(0.0f, 1.0f, 0.0f);
  int turned_hinges = 0;
  for (std::uint64_t p = 0; p < 100; ++p) {
    const Pose pose = random_pose(rig, space.ranges, 12, p);
    for (const char* side : {"Left", "Right"}) {
      const std::string t = std::string(side) + "HandThumb";
      for (int k = 1; k <= 3; ++k) {
        const auto [bone, turned] = tip(pose, t + std::to_string(k), t + std::to_string(k + 1));
        const glm::quat q = pose[joint(t + std::to_string(k))].rotation;  // bind rotations are identity
        const float twist = 2.0f * std::atan2(glm::dot(glm::vec3(q.x, q.y, q.z), bone), q.w);
        if (k == 1) {
          EXPECT_LE(std::abs(twist), 0.06f) << t << k << ", pose " << p;
          continue;
        }
        const float angle = glm::angle(q);
        if (angle < 0.05f) continue;
        const glm::vec3 axis = glm::axis(q);
        EXPECT_LT(std::abs(glm::dot(axis, bone)), 0.01f) << t << k << ", pose " << p;
        EXPECT_GT(std::abs(glm::dot(axis, glm::normalize(glm::cross(bone, up)))), 0.99f) << t << k << ", pose " << p;
        EXPECT_LE(angle, 0.5f + 1e-4f) << t << k << ", pose " << p;
        ++turned_hinges;
      }
    }
  }
  EXPECT_GT(turned_hinges, 300);  // of 400

  // Without a thumb to tell the palm's side, fingers curl as far both ways.
  for (std::string& name : rig.names)
    if (name.find("Thumb") != std::string::npos) name.replace(name.find("Thumb"), 5, "Digit");
  const PoseSpace thumbless = pose_space(rig, SkinnedPoseAO{});
  for (const char* finger : {"LeftHandIndex1", "LeftHandRing2", "RightHandPinky3"}) {
    const JointRange& r = thumbless.ranges[joint(finger)];
    EXPECT_FLOAT_EQ(r.max.z, 0.5f) << finger;
    EXPECT_FLOAT_EQ(r.min.z, -0.5f) << finger;
  }
}

// Mean of `ao` over the body's upward-facing vertices under the left sleeve (the gear's tube of
// radius 8 cm about the upper arm from x = 17 to 29 cm, in the bind pose).
double under_the_pad(const MeshData& body, std::span<const float> ao) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t v = 0; v < ao.size(); ++v) {
    const glm::vec3 p = body.positions[v];
    if (p.x > 19.0f && p.x < 27.0f && p.y > 148.0f && body.normals[v].y > 0.7f) {
      sum += ao[v];
      ++n;
    }
  }
  EXPECT_GT(n, 10u);
  return sum / double(std::max<std::size_t>(n, 1));
}
// The same, traced in a pose.
double under_the_pad(PoseAOTracer& tracer, const MeshData& body, std::span<const glm::mat4> pose, JobContext& jobs) {
  std::vector<float> ao(body.positions.size());
  EXPECT_TRUE(tracer.trace(pose, 64, 7, jobs, ao));
  return under_the_pad(body, ao);
}

TEST(PoseAOProductionRig, TheCharactersMeshesAreTracedTogether) {
  Humanoid h;
  ASSERT_TRUE(h.body && h.gear);
  std::vector<std::string> notes;
  const std::vector<PoseAOOccluder> occluders = character_occluders(*h.world, h.body, &notes);
  ASSERT_EQ(occluders.size(), 1u);  // the gear; nothing else shares the skeleton
  EXPECT_TRUE(notes.empty());
  EXPECT_EQ(occluders.front().mesh, h.world->get<Mesh>(h.gear).data);
  auto rig = make_pose_rig(*h.world, h.body, "humanoid").value();
  const auto body = h.world->get<Mesh>(h.body).data;
  auto alone = PoseAOTracer::create(body, rig.joint_count(), "body").value();
  auto together = PoseAOTracer::create(body, rig.joint_count(), "body", occluders).value();
  EXPECT_EQ(together.occluder_count(), 1u);
  JobContext jobs;
  const std::vector<glm::mat4> bind(rig.joint_count(), glm::mat4(1.0f));
  // The pad sits 2.5 cm above the upper arm's top: open sky alone, shadowed under the pad.
  const double open = under_the_pad(alone, *body, bind, jobs), shadowed = under_the_pad(together, *body, bind, jobs);
  EXPECT_GT(open, 0.8);
  EXPECT_LT(shadowed, 0.4);
  // The pad follows the arm: with the arm raised 0.6 rad (and the vertices chosen in the bind
  // pose), the upper arm stays shadowed, no more than in the bind pose plus the noise.
  Pose raised = rig.bind;
  for (std::size_t j = 0; j < rig.joint_count(); ++j)
    if (rig.names[j] == "mixamorig:LeftArm") raised[j].rotation = glm::angleAxis(0.6f, glm::vec3(0, 0, 1));
  const std::vector<glm::mat4> m = skinning_matrices(rig, raised);
  const double raised_together = under_the_pad(together, *body, m, jobs);
  const double raised_alone = under_the_pad(alone, *body, m, jobs);
  EXPECT_LT(raised_together, shadowed + 0.1);
  EXPECT_GT(raised_alone, raised_together + 0.3);  // the raised arm meets the shoulder, but no pad

  // The bake traces them together too, and says so in its AO: the bind-pose AO under the pad.
  SkinnedPoseAO s = quick();
  s.reference_poses = 20;
  s.clip_poses = 1;
  MemoryBudget budget;
  auto data = bake_pose_ao(*h.world, h.body, s, 1, jobs, budget);
  ASSERT_TRUE(data) << data.error().message;
  EXPECT_LT(under_the_pad(*body, data->bind_ao), 0.45);

  // Another level of detail of the body, or another entity of the body's mesh, on the same
  // skeleton lies on its surface: left out (while a mesh of its own LOD level would be traced).
  const auto add_body_like = [&](std::string name, std::shared_ptr<const MeshData> mesh) {
    const Entity e = h.world->create();
    h.world->add<Name>(e, Name{std::move(name)});
    h.world->add<Mesh>(e, Mesh{std::move(mesh)});
    h.world->add<Skin>(e, h.world->get<Skin>(h.body));
    h.world->add<WorldTransform>(e, h.world->get<WorldTransform>(h.body));
    return e;
  };
  add_body_like("body_LOD1", std::make_shared<const MeshData>(*body));
  add_body_like("body_again", body);
  EXPECT_EQ(character_meshes(*h.world, h.body).size(), 2u);  // the body and the gear
  EXPECT_EQ(character_occluders(*h.world, h.body).size(), 1u);
}

TEST(PoseAOProductionRig, TheOptionalGroundDarkensTheFeetAndNotTheHead) {
  Humanoid h;
  SkinnedPoseAO s = quick();
  s.reference_poses = 12;
  s.clip_poses = 1;
  s.locality = 1;
  JobContext jobs;
  MemoryBudget budget;
  auto open = bake_pose_ao(*h.world, h.body, s, 1, jobs, budget);
  s.ground = true;
  auto grounded = bake_pose_ao(*h.world, h.body, s, 1, jobs, budget);
  ASSERT_TRUE(open && grounded);
  const MeshData& body = *h.world->get<Mesh>(h.body).data;
  double feet_open = 0, feet_ground = 0, head_open = 0, head_ground = 0;
  std::size_t feet = 0, head = 0;
  for (std::size_t v = 0; v < body.positions.size(); ++v) {
    // The armature scales centimetres to metres: the toes' undersides lie within 3 cm of the floor.
    if (body.positions[v].y < 3.0f) {
      feet_open += open->bind_ao[v];
      feet_ground += grounded->bind_ao[v];
      ++feet;
    }
    if (body.positions[v].y > 178.0f) {
      head_open += open->bind_ao[v];
      head_ground += grounded->bind_ao[v];
      ++head;
    }
  }
  ASSERT_GT(feet, 10u);
  ASSERT_GT(head, 10u);
  EXPECT_GT(feet_open / double(feet), feet_ground / double(feet) + 0.2);
  EXPECT_NEAR(head_open / double(head), head_ground / double(head), 0.02);
}

// CesiumMan stores its vertices Z-up under a node that turns them Y-up: the ground follows world
// up into the mesh's frame and lies under the feet.
TEST(PoseAOProductionRig, TheGroundLiesUnderAZUpCharactersFeet) {
  const std::string path = cesium_man_path();
  if (path.empty()) GTEST_SKIP() << "CesiumMan.glb not found (the shared assets are not checked out)";
  World world;
  const Entity mesh = load_skinned(world, path);
  ASSERT_TRUE(mesh);
  const MeshData& data = *world.get<Mesh>(mesh).data;
  const PoseAOOccluder ground = ground_occluder(data, {}, world.get<WorldTransform>(mesh).matrix);
  const glm::vec3 up = ground.mesh->normals[0];
  // The character's height is along the ground's normal, and every vertex is on its upper side.
  const glm::vec3 extent = data.bounds.extent();
  const int tallest = extent.x > extent.y ? (extent.x > extent.z ? 0 : 2) : (extent.y > extent.z ? 1 : 2);
  EXPECT_GT(std::abs(up[tallest]), 0.99f) << up.x << " " << up.y << " " << up.z;
  const float floor = glm::dot(ground.mesh->positions[0], up);
  float lowest = 1e30f;
  for (const glm::vec3& p : data.positions) lowest = std::min(lowest, glm::dot(p, up) - floor);
  EXPECT_NEAR(lowest, 0.0f, 1e-4f * glm::length(extent));
}

TEST(PoseAOProductionRig, AMeshOnJointsTheSkinLacksIsLeftOutWithANote) {
  Humanoid h;
  // The gear's skin gets a joint of its own (a cape bone) that its first vertex follows.
  const Entity cape = h.world->create();
  h.world->add<Name>(cape, Name{"cape_01"});
  h.world->add<Transform>(cape);
  h.world->add<WorldTransform>(cape);
  Skin& skin = h.world->patch<Skin>(h.gear);
  skin.joints.push_back(cape);
  skin.inverse_bind.push_back(glm::mat4(1.0f));
  auto mesh = std::make_shared<MeshData>(*h.world->get<Mesh>(h.gear).data);
  mesh->joints[0] = glm::u16vec4(static_cast<std::uint16_t>(skin.joints.size() - 1), 0, 0, 0);
  mesh->weights[0] = glm::vec4(1, 0, 0, 0);
  h.world->patch<Mesh>(h.gear).data = mesh;
  std::vector<std::string> notes;
  EXPECT_TRUE(character_occluders(*h.world, h.body, &notes).empty());
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("'gear' is not traced with 'body'"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("'cape_01'"), std::string::npos) << notes[0];
}

TEST(PoseAOExtremes, VerticesWithoutSkinWeightsFollowTheMesh) {
  Walker w;
  // The head (the last 162 vertices, an icosphere on the spine) loses its weights.
  auto mesh = std::make_shared<MeshData>(w.data());
  const std::size_t n = mesh->positions.size(), head = n - 162;
  for (std::size_t v = head; v < n; ++v) mesh->weights[v] = glm::vec4(0.0f);
  w.world->patch<Mesh>(w.mesh).data = mesh;
  SkinnedPoseAO s = quick();
  JobContext jobs;
  MemoryBudget budget;
  auto data = bake_pose_ao(*w.world, w.mesh, s, 4, jobs, budget);
  ASSERT_TRUE(data) << data.error().message;
  // The head stays where it was (not collapsed onto the origin): open above, as in the bind pose,
  // and the same in every pose (nothing moving comes near it).
  auto rig = make_pose_rig(*w.world, w.mesh, "walker").value();
  std::vector<float> f, ao(n);
  pose_features(rig.parents, skinning_matrices(rig, clip_pose(rig, 0, 0.3f)), f);
  evaluate_pose_ao(*data, f, ao);
  for (std::size_t v = head; v < n; ++v) {
    EXPECT_NEAR(data->bind_ao[v], data->mean_ao[v], 0.1f) << v;
    EXPECT_NEAR(ao[v], data->bind_ao[v], 0.1f) << v;
  }
}

// The walker scaled by s: mesh, inverse binds, joint translations and the clip's translations.
void scale_walker(Walker& w, float s) {
  auto mesh = std::make_shared<MeshData>(w.data());
  for (glm::vec3& p : mesh->positions) p *= s;
  mesh->bounds.min *= s;
  mesh->bounds.max *= s;
  w.world->patch<Mesh>(w.mesh).data = mesh;
  Skin& skin = w.world->get<Skin>(w.mesh);
  for (glm::mat4& m : skin.inverse_bind) m[3] = glm::vec4(glm::vec3(m[3]) * s, 1.0f);
  for (Entity j : skin.joints) w.world->patch<Transform>(j).translation *= s;
  w.world->view<Animator>().each([&](Entity, Animator& a) {
    auto clips = std::make_shared<std::vector<AnimationClip>>(*a.clips);
    for (AnimationClip& c : *clips)
      for (AnimationChannel& ch : c.channels)
        if (ch.path == AnimationChannel::Path::Translation)
          for (glm::vec4& v : ch.values) v *= s;
    a.clips = clips;
  });
  update_world_transforms(*w.world);
  update_skin_poses(*w.world);
}

TEST(PoseAOExtremes, ScaleByMilliAndTenThousandGivesTheSameAO) {
  SkinnedPoseAO s = quick();
  s.reference_poses = 20;
  std::vector<PoseAOData> baked;
  for (float scale : {1.0f, 1e-3f, 1e4f}) {
    Walker w;
    if (scale != 1.0f) scale_walker(w, scale);
    JobContext jobs;
    MemoryBudget budget;
    auto data = bake_pose_ao(*w.world, w.mesh, s, 6, jobs, budget);
    ASSERT_TRUE(data) << scale << ": " << data.error().message;
    baked.push_back(std::move(*data));
  }
  for (std::size_t i = 1; i < baked.size(); ++i) {
    double diff = 0.0, worst = 0.0;
    for (std::size_t v = 0; v < baked[0].vertex_count; ++v) {
      const double d = std::abs(double(baked[i].mean_ao[v]) - baked[0].mean_ao[v]);
      diff += d;
      worst = std::max(worst, std::abs(double(baked[i].bind_ao[v]) - baked[0].bind_ao[v]));
    }
    EXPECT_LT(diff / baked[0].vertex_count, 2e-3) << i;
    EXPECT_LT(worst, 0.13) << i;  // a ray or two of 16 may flip at a grazing contact
    EXPECT_NEAR(baked[i].training_rmse, baked[0].training_rmse, 5e-3f) << i;
  }
}

TEST(PoseAOBake, BudgetAndCancel) {
  Walker w;
  JobContext jobs;
  MemoryBudget tiny(1024);
  auto data = bake_pose_ao(*w.world, w.mesh, quick(), 1, jobs, tiny);
  ASSERT_FALSE(data);
  EXPECT_EQ(data.error().code, ErrorCode::OutOfBudget);
  CancelToken cancel;
  cancel.cancel();
  JobContext cancelled(nullptr, {}, &cancel);
  MemoryBudget budget;
  auto none = bake_pose_ao(*w.world, w.mesh, quick(), 1, cancelled, budget);
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, ErrorCode::Cancelled);
  EXPECT_EQ(budget.reserved(), 0u);
}

TEST(PoseAOBake, BakeWorldAttachAndTheSystemFollowTheWalkCycle) {
  Walker w;
  World& world = *w.world;
  register_scene_systems(world);
  register_pose_ao_system(world);
  register_pose_ao_baker(world);
  EXPECT_EQ(add_default_pose_ao(world, Preset::Draft), 1u);
  EXPECT_EQ(add_default_pose_ao(world, Preset::Draft), 0u);
  SkinnedPoseAO& s = world.patch<SkinnedPoseAO>(w.mesh);
  s = quick();
  world.update(0.0);
  JobContext jobs;
  auto baked = bake_world(world, {"pose-ao"}, BakeSettings{}, jobs);
  ASSERT_TRUE(baked) << baked.error().message;
  ASSERT_EQ(baked->file.chunks.size(), 1u);
  EXPECT_EQ(baked->file.chunks[0].label, chunk_label("pose-ao", entity_key(world, w.mesh)));
  ASSERT_TRUE(world.get<SkinnedPoseAO>(w.mesh).data);

  // A fresh component loads the chunk.
  world.patch<SkinnedPoseAO>(w.mesh).data.reset();
  ASSERT_TRUE(attach_bake(world, baked->file));
  ASSERT_TRUE(world.get<SkinnedPoseAO>(w.mesh).data);

  // Two times of the walk cycle: the AO differs, and stays in [0, 1].
  world.update(0.25);
  const std::vector<float> a = world.get<VertexAO>(w.mesh).ao;
  world.update(0.5);
  const std::vector<float> b = world.get<VertexAO>(w.mesh).ao;
  ASSERT_EQ(a.size(), w.data().positions.size());
  double change = 0.0;
  for (std::size_t v = 0; v < a.size(); ++v) {
    EXPECT_TRUE(a[v] >= 0.0f && a[v] <= 1.0f);
    change = std::max(change, std::abs(double(a[v]) - b[v]));
  }
  EXPECT_GT(change, 0.05);

  // A chunk for an entity without the component is refused.
  world.remove<SkinnedPoseAO>(w.mesh);
  auto refused = attach_bake(world, baked->file);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::NotFound);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// Instances of one character share one bake, and the shared model gives the instance the same AO
// in the same pose; what has no SkinnedPoseAO, or no Skin, is left alone.
TEST(PoseAOShare, InstancesOfOneCharacterShareItsBake) {
  Walker w;
  World& world = *w.world;
  register_scene_systems(world);
  register_pose_ao_system(world);
  register_pose_ao_baker(world);
  ASSERT_EQ(add_default_pose_ao(world, Preset::Draft), 1u);
  world.patch<SkinnedPoseAO>(w.mesh) = quick();
  world.update(0.0);
  JobContext jobs;
  ASSERT_TRUE(bake_world(world, {"pose-ao"}, BakeSettings{}, jobs));
  const Entity original = world.get<Parent>(w.mesh).entity;
  Transform at;
  at.translation = glm::vec3(-4.0f, 0.0f, 3.0f);
  const Entity copy = add_builtin_character(world, Entity::null(), at, "copy");
  EXPECT_EQ(share_pose_ao(world, original, world, copy), 0u);  // no SkinnedPoseAO on the copy yet
  ASSERT_EQ(add_default_pose_ao(world, Preset::Draft), 1u);
  EXPECT_EQ(share_pose_ao(world, original, world, copy), 1u);
  Entity copy_mesh;
  world.view<const SkinnedPoseAO>().each([&](Entity e, const SkinnedPoseAO&) {
    if (e != w.mesh) copy_mesh = e;
  });
  EXPECT_EQ(world.get<SkinnedPoseAO>(copy_mesh).data, world.get<SkinnedPoseAO>(w.mesh).data);
  world.update(0.0);  // both in the bind pose: the same AO
  EXPECT_EQ(world.get<VertexAO>(copy_mesh).ao, world.get<VertexAO>(w.mesh).ao);
  // A mesh without a Skin is no instance of the character: nothing is shared.
  const Entity box = world.create();
  world.add<Mesh>(box, world.get<Mesh>(w.mesh));
  EXPECT_EQ(share_pose_ao(world, original, world, box), 0u);
}

}  // namespace
}  // namespace penumbra
