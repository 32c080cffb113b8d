// Humanoid joint roles and sides from joint names, and each role's range of motion: the pose space
// of a character whose file carries no usable clip (pose_ao_baker.h, pose_space).
//
// joint_role recognises the naming conventions of the common character pipelines, e.g.
//   Mixamo        "mixamorig:LeftForeArm", "mixamorig:RightHandIndex2", "mixamorig:LeftUpLeg"
//   Unreal        "upperarm_l", "lowerarm_r", "thigh_l", "calf_r", "ball_l", "index_02_l"
//   3ds Max Biped "Bip01 L Forearm", "Bip01 R Thigh", "Bip01 L Finger11", "Bip01 HeadNub"
//   Blender       "upper_arm.L", "forearm.R", "shin.L", "DEF-thigh.R"
// by the words in the name, case-insensitively, after dropping a namespace prefix ("...:" or
// "...|") and splitting camel case; side words are ignored. End joints (a word "end" as in
// "Toe_End" or "HeadTop_End", "Nub", a word "tip") are leaves no geometry hangs from. A name that
// matches nothing is Unknown.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/result.h"

namespace penumbra {

enum class JointRole : unsigned char {
  Unknown,
  Hips,         // pelvis, the hierarchy's root joint
  Spine,        // spine, chest, abdomen
  Neck,
  Head,
  Clavicle,     // shoulder / collar bone
  UpperArm,
  Forearm,
  Hand,
  Finger,       // a finger's or thumb's first joint (knuckle), below the hand
  FingerHinge,  // a finger or thumb joint below another (assign_chain_roles): bends, no spread
  Thigh,
  Calf,         // shin, lower leg, knee
  Foot,
  Toe,
  End,          // a leaf marker joint
};

// The role of the joint named `name`. Cost: O(name length). Thread-safe.
JointRole joint_role(std::string_view name);

// "forearm", "finger", ... ("unknown" for Unknown).
const char* to_string(JointRole role);

// Generic names give a whole limb one role ("leg_joint_L_1", "_2", "_3" are all Calf,
// "arm_joint_L_2" all UpperArm). A chain of two or more joints of UpperArm (or Calf), each the
// only child of that role of the one before (the last with none), with no joint of the limb's
// other roles among its ancestors and descendants (an Unreal "upperarm_twist_01_l" sits beside a
// "lowerarm_l"), takes the limb's roles in order: upper arm, forearm, hand, then finger; thigh,
// calf, foot, then toe. Then a Finger joint whose parent is a Finger becomes FingerHinge: the
// middle and distal phalanges' joints (and the thumb's last two) are hinges, which bend but do not
// spread or twist. `parents[j]` is joint j's parent (-1 for a root; a cycle stops the walks).
// Precondition: roles.size() == parents.size(). Cost: O(joints x (depth + limb joints)).
void assign_chain_roles(std::span<const std::int32_t> parents, std::span<JointRole> roles);

// The per-axis limit of a role, for a joint whose role_motion cannot be placed on its bone
// (pose_space): the joint turns within +-limit radians about each axis of its bind frame. Human
// ranges of motion, conservative: forearm 1.0, upper arm 0.9, calf 0.9, thigh 0.7, hand 0.6,
// finger and finger hinge 0.5, head 0.4, foot 0.4, neck 0.35, toe 0.3, spine 0.25, clavicle 0.25,
// hips 0.3; End 0; Unknown returns `unknown`.
float role_limit(JointRole role, float unknown);

// The side of the body a joint is on, from the side words of its name ("Left", "L", "_l", ".R",
// "Bip01 R ..."): None for a name without one (the midline). Cost: O(name length). Thread-safe.
enum class JointSide : unsigned char { None, Left, Right };
JointSide joint_side(std::string_view name);

// Whether `name` names a thumb joint ("mixamorig:LeftHandThumb2", "thumb_01_l", "Bip01 L Finger0",
// "Bip01 L Finger01"). Cost: O(name length). Thread-safe.
bool is_thumb(std::string_view name);

// A direction of the character's body in its bind pose, found from its skeleton
// (pose_ao_baker.h, pose_space).
enum class BodyDirection : unsigned char {
  Forward,  // where the character faces
  Up,       // from the hips to the head
  Left,     // the character's left
  Medial,   // towards the body's midline: Left for a joint on the right side
  Palm,     // towards the palm of the finger's hand (pose_space finds it from the knuckles and the
            // thumb); where it cannot, Up, with the swing's range made symmetric
};

// A role's anatomical range of motion about its bone (the joint to its children): a twist within
// +-twist about the bone, and two swings, each an angle in [lo, hi] about the axis bone x towards,
// so that a positive swing moves the bone's tip towards `towards`. Human ranges, conservative:
// the knee bends backward only (Forward, [-1.4, 0]), the elbow forward only, the hip flexes 1.2
// rad forward and extends 0.5 back, abducts 0.6 and crosses the midline by 0.2; a finger's knuckle
// curls 0.8 towards the palm, extends 0.2 and spreads +-0.15, its hinges beyond curl 1.0 and do
// nothing else. Where a role bends one way only, limits per axis (role_limit) would bend it both
// ways and through the body.
struct RoleMotion {
  struct Swing {
    BodyDirection towards = BodyDirection::Forward;
    float lo = 0.0f, hi = 0.0f;
  };
  float twist = 0.0f;
  std::array<Swing, 2> swings{};
};
// The motion of `role`; nullopt for Unknown, Hips (the root turns the whole body) and End.
std::optional<RoleMotion> role_motion(JointRole role);

// A limit set by name (SkinnedPoseAO::joint_limits): the joints whose names match `pattern` turn
// within +-limit radians about each axis.
struct JointLimit {
  std::string pattern;  // '*' matches any run of characters; matched, case-sensitively, against the
                        // whole name and against the name without its namespace prefix ("mixamorig:")
  float limit = 0.0f;
};

// Parses "PATTERN=RADIANS" entries separated by ',' or ';' (spaces around them ignored), e.g.
// "LeftForeArm=1.2, *Spine*=0.3, *Hand*=0": later entries override earlier ones on the joints
// they share. InvalidArgument naming the entry: no '=', an empty pattern, a limit that is not a
// number in [0, pi]. An empty text gives no limit. Cost: O(text length).
Result<std::vector<JointLimit>> parse_joint_limits(std::string_view text);

// Whether `name` matches `pattern` as JointLimit describes. Cost: O(pattern x name).
bool joint_name_matches(std::string_view pattern, std::string_view name);

}  // namespace penumbra
