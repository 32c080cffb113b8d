#include "penumbra/pose_ao/joint_roles.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {

struct Case {
  const char* name;
  JointRole role;
};

// The naming conventions of the common pipelines (joint_roles.h).
TEST(JointRoles, TheCommonNamingConventionsAreRecognised) {
  const Case cases[] = {
      // Mixamo
      {"mixamorig:Hips", JointRole::Hips}, {"mixamorig:Spine2", JointRole::Spine},
      {"mixamorig:Neck", JointRole::Neck}, {"mixamorig:Head", JointRole::Head},
      {"mixamorig:HeadTop_End", JointRole::End}, {"mixamorig:LeftShoulder", JointRole::Clavicle},
      {"mixamorig:LeftArm", JointRole::UpperArm}, {"mixamorig:LeftForeArm", JointRole::Forearm},
      {"mixamorig:RightHand", JointRole::Hand}, {"mixamorig:RightHandIndex2", JointRole::Finger},
      {"mixamorig:LeftHandThumb1", JointRole::Finger}, {"mixamorig:LeftUpLeg", JointRole::Thigh},
      {"mixamorig:LeftLeg", JointRole::Calf}, {"mixamorig:RightFoot", JointRole::Foot},
      {"mixamorig:RightToeBase", JointRole::Toe}, {"mixamorig:LeftToe_End", JointRole::End},
      // Unreal
      {"pelvis", JointRole::Hips}, {"spine_03", JointRole::Spine}, {"clavicle_l", JointRole::Clavicle},
      {"upperarm_l", JointRole::UpperArm}, {"lowerarm_r", JointRole::Forearm}, {"hand_l", JointRole::Hand},
      {"index_02_l", JointRole::Finger}, {"index_metacarpal_l", JointRole::Hand}, {"thigh_r", JointRole::Thigh},
      {"calf_l", JointRole::Calf}, {"foot_r", JointRole::Foot}, {"ball_l", JointRole::Toe},
      {"upperarm_twist_01_l", JointRole::UpperArm},
      // 3ds Max Biped
      {"Bip01 Pelvis", JointRole::Hips}, {"Bip01 L Clavicle", JointRole::Clavicle},
      {"Bip01 L UpperArm", JointRole::UpperArm}, {"Bip01 L Forearm", JointRole::Forearm},
      {"Bip01 R Finger12", JointRole::Finger}, {"Bip01 R Thigh", JointRole::Thigh},
      {"Bip01 L Calf", JointRole::Calf}, {"Bip01 L Toe0", JointRole::Toe}, {"Bip01 HeadNub", JointRole::End},
      // Blender (Rigify deform bones)
      {"DEF-upper_arm.L", JointRole::UpperArm}, {"DEF-forearm.R", JointRole::Forearm},
      {"DEF-thigh.L", JointRole::Thigh}, {"DEF-shin.R", JointRole::Calf}, {"shoulder.L", JointRole::Clavicle},
      // The courtyard's walker
      // Daz Genesis: "Bend" joints bend, they are no end markers
      {"lForearmBend", JointRole::Forearm}, {"lThighBend", JointRole::Thigh}, {"rShin", JointRole::Calf},
      {"left_thigh", JointRole::Thigh}, {"right_shin", JointRole::Calf}, {"left_arm", JointRole::UpperArm},
      // Nothing to go by
      {"Bip01", JointRole::Unknown}, {"root", JointRole::Unknown}, {"joint_17", JointRole::Unknown},
      {"", JointRole::Unknown},
  };
  for (const Case& c : cases) EXPECT_EQ(joint_role(c.name), c.role) << c.name << ": " << to_string(joint_role(c.name));
}

TEST(JointRoles, LimitsAreHumanAndEndJointsStayFixed) {
  EXPECT_EQ(role_limit(JointRole::End, 0.5f), 0.0f);
  EXPECT_EQ(role_limit(JointRole::Unknown, 0.37f), 0.37f);
  // A forearm bends further than a finger segment, a finger further than the spine.
  EXPECT_GT(role_limit(JointRole::Forearm, 0.5f), role_limit(JointRole::Finger, 0.5f));
  EXPECT_GT(role_limit(JointRole::Finger, 0.5f), role_limit(JointRole::Spine, 0.5f));
  for (int r = 0; r <= static_cast<int>(JointRole::End); ++r) {
    const float limit = role_limit(static_cast<JointRole>(r), 0.5f);
    EXPECT_TRUE(limit >= 0.0f && limit <= 1.2f) << to_string(static_cast<JointRole>(r));
  }
}

TEST(JointRoles, ALimbNamedAsOneChainTakesItsPartsInOrder) {
  // 0 spine; 1-4 "leg_1".."leg_4" (all Calf by name); 5-8 "arm_1".."arm_4" (all UpperArm), arm_2
  // with two children of the role (7, 8: the chain branches, so it is left as named); 9-11 an Unreal
  // arm, upperarm_l (9) with lowerarm_l (10) and upperarm_twist_01_l (11): left as named.
  const std::vector<std::int32_t> parents = {-1, 0, 1, 2, 3, 0, 5, 6, 6, 0, 9, 9};
  using R = JointRole;
  std::vector<R> roles = {R::Spine,    R::Calf,     R::Calf,     R::Calf,     R::Calf,    R::UpperArm,
                          R::UpperArm, R::UpperArm, R::UpperArm, R::UpperArm, R::Forearm, R::UpperArm};
  assign_chain_roles(parents, roles);
  const std::vector<R> expected = {R::Spine,    R::Thigh,    R::Calf,     R::Foot,     R::Toe,     R::UpperArm,
                                   R::UpperArm, R::UpperArm, R::UpperArm, R::UpperArm, R::Forearm, R::UpperArm};
  for (std::size_t j = 0; j < roles.size(); ++j) EXPECT_EQ(roles[j], expected[j]) << j << ": " << to_string(roles[j]);
  // Two arms off the spine, each a chain of one: nothing changes.
  std::vector<R> branch = {R::Spine, R::UpperArm, R::UpperArm};
  assign_chain_roles(std::vector<std::int32_t>{-1, 0, 0}, branch);
  EXPECT_EQ(branch[1], JointRole::UpperArm);
  EXPECT_EQ(branch[2], JointRole::UpperArm);
  // A cycle (not a hierarchy) stops the walks.
  std::vector<R> loop = {R::Calf, R::Calf};
  assign_chain_roles(std::vector<std::int32_t>{1, 0}, loop);
  EXPECT_EQ(loop, (std::vector<R>{R::Calf, R::Calf}));
}

TEST(JointRoles, AFingerJointBelowAnotherIsAHinge) {
  // 0 hand; 1-4 a finger's knuckle, two hinges and its end joint; 5 an Unreal metacarpal (Hand by
  // name) with 6 its knuckle and 7 the next joint; 8 a finger joint on the hand's parent's side.
  using R = JointRole;
  std::vector<R> roles = {R::Hand, R::Finger, R::Finger, R::Finger, R::Finger,
                          R::Hand, R::Finger, R::Finger, R::Finger};
  assign_chain_roles(std::vector<std::int32_t>{-1, 0, 1, 2, 3, 0, 5, 6, -1}, roles);
  EXPECT_EQ(roles, (std::vector<R>{R::Hand, R::Finger, R::FingerHinge, R::FingerHinge, R::FingerHinge, R::Hand,
                                   R::Finger, R::FingerHinge, R::Finger}));
  // Both curl towards the palm; a knuckle extends a little, a hinge not at all, and it neither
  // twists nor spreads.
  const RoleMotion knuckle = role_motion(R::Finger).value(), hinge = role_motion(R::FingerHinge).value();
  EXPECT_EQ(knuckle.swings[0].towards, BodyDirection::Palm);
  EXPECT_EQ(hinge.swings[0].towards, BodyDirection::Palm);
  EXPECT_LT(knuckle.swings[0].lo, 0.0f);
  EXPECT_GT(knuckle.swings[0].hi, -2.0f * knuckle.swings[0].lo);
  EXPECT_EQ(hinge.swings[0].lo, 0.0f);
  EXPECT_GT(hinge.swings[0].hi, 0.5f);
  EXPECT_GT(knuckle.swings[1].hi, 0.0f);
  EXPECT_EQ(hinge.swings[1].lo, 0.0f);
  EXPECT_EQ(hinge.swings[1].hi, 0.0f);
  EXPECT_EQ(hinge.twist, 0.0f);
}

TEST(JointRoles, ThumbsAreKnownByName) {
  for (const char* thumb : {"mixamorig:LeftHandThumb1", "mixamorig:RightHandThumb3", "thumb_01_l", "Bip01 L Finger0",
                            "Bip01 R Finger02", "DEF-thumb.02.L"})
    EXPECT_TRUE(is_thumb(thumb)) << thumb;
  for (const char* other : {"mixamorig:LeftHandIndex1", "index_01_l", "Bip01 L Finger1", "Bip01 R Finger12",
                            "Bip01 R Finger10", "mixamorig:LeftHand", ""})
    EXPECT_FALSE(is_thumb(other)) << other;
}

TEST(JointRoles, SidesComeFromTheSideWordsOfEachConvention) {
  const std::pair<const char*, JointSide> cases[] = {
      {"mixamorig:LeftForeArm", JointSide::Left}, {"mixamorig:RightHandIndex2", JointSide::Right},
      {"upperarm_l", JointSide::Left},           {"calf_r", JointSide::Right},
      {"Bip01 L Forearm", JointSide::Left},      {"Bip01 R Thigh", JointSide::Right},
      {"DEF-thigh.R", JointSide::Right},         {"upper_arm.L", JointSide::Left},
      {"lForearmBend", JointSide::Left},         {"rShin", JointSide::Right},
      {"left_thigh", JointSide::Left},           {"mixamorig:Spine2", JointSide::None},
      {"Bip01 Pelvis", JointSide::None},         {"neck_01", JointSide::None},
      {"", JointSide::None},
  };
  for (const auto& [name, side] : cases) EXPECT_EQ(joint_side(name), side) << name;
}

TEST(JointRoles, KneesAndElbowsBendOneWayAndEveryMotionIsHuman) {
  // The knee bends backward only, the elbow forward only (role_motion's sign convention: a
  // positive swing moves the bone's tip towards the swing's direction).
  const RoleMotion knee = role_motion(JointRole::Calf).value();
  EXPECT_EQ(knee.swings[0].towards, BodyDirection::Forward);
  EXPECT_LT(knee.swings[0].lo, -1.0f);
  EXPECT_EQ(knee.swings[0].hi, 0.0f);
  const RoleMotion elbow = role_motion(JointRole::Forearm).value();
  EXPECT_EQ(elbow.swings[0].towards, BodyDirection::Forward);
  EXPECT_EQ(elbow.swings[0].lo, 0.0f);
  EXPECT_GT(elbow.swings[0].hi, 1.0f);
  // A hip flexes forward further than it extends, and crosses the midline less than it abducts.
  const RoleMotion hip = role_motion(JointRole::Thigh).value();
  EXPECT_GT(hip.swings[0].hi, -hip.swings[0].lo);
  EXPECT_EQ(hip.swings[1].towards, BodyDirection::Medial);
  EXPECT_LT(hip.swings[1].hi, -hip.swings[1].lo);
  for (const JointRole r : {JointRole::Unknown, JointRole::Hips, JointRole::End})
    EXPECT_FALSE(role_motion(r)) << to_string(r);
  for (int r = 0; r <= static_cast<int>(JointRole::End); ++r) {
    const std::optional<RoleMotion> m = role_motion(static_cast<JointRole>(r));
    if (!m) continue;
    EXPECT_TRUE(m->twist >= 0.0f && m->twist <= 1.0f) << to_string(static_cast<JointRole>(r));
    for (const RoleMotion::Swing& s : m->swings) {
      EXPECT_LE(s.lo, 0.0f) << to_string(static_cast<JointRole>(r));
      EXPECT_GE(s.hi, 0.0f) << to_string(static_cast<JointRole>(r));
      EXPECT_LE(s.hi - s.lo, 2.0f) << to_string(static_cast<JointRole>(r));
    }
    EXPECT_NE(m->swings[0].towards, m->swings[1].towards) << to_string(static_cast<JointRole>(r));
  }
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(JointLimits, EntriesParseAndBadOnesAreNamed) {
  auto limits = parse_joint_limits(" LeftForeArm = 1.2; *Spine*=0.3 ,,*Hand*=0 ");
  ASSERT_TRUE(limits) << limits.error().message;
  ASSERT_EQ(limits->size(), 3u);
  EXPECT_EQ((*limits)[0].pattern, "LeftForeArm");
  EXPECT_FLOAT_EQ((*limits)[0].limit, 1.2f);
  EXPECT_EQ((*limits)[1].pattern, "*Spine*");
  EXPECT_EQ((*limits)[2].limit, 0.0f);
  EXPECT_TRUE(parse_joint_limits("")->empty());
  for (const char* bad : {"LeftForeArm", "=0.3", "Spine=", "Spine=abc", "Spine=-0.1", "Spine=4", "Spine=0.3x"}) {
    auto r = parse_joint_limits(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_NE(r.error().message.find(std::string("'") + bad + "'"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("PATTERN=RADIANS"), std::string::npos);
  }
}

TEST(JointLimits, PatternsMatchTheNameOrItWithoutItsPrefix) {
  EXPECT_TRUE(joint_name_matches("LeftForeArm", "mixamorig:LeftForeArm"));
  EXPECT_TRUE(joint_name_matches("mixamorig:LeftForeArm", "mixamorig:LeftForeArm"));
  EXPECT_FALSE(joint_name_matches("LeftArm", "mixamorig:LeftForeArm"));
  EXPECT_TRUE(joint_name_matches("*Spine*", "mixamorig:Spine2"));
  EXPECT_TRUE(joint_name_matches("*Hand*", "mixamorig:LeftHandIndex3"));
  EXPECT_TRUE(joint_name_matches("*", "anything"));
  EXPECT_FALSE(joint_name_matches("Spine", "Spine1"));
  EXPECT_TRUE(joint_name_matches("S*e*1", "Spine1"));
  EXPECT_FALSE(joint_name_matches("S*x*1", "Spine1"));
}

}  // namespace
}  // namespace penumbra
