// Humanoid joint roles from joint names, and the default rotation limit of each role: the pose
// space of a character whose file carries no usable clip (pose_ao_baker.h, pose_space).
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

#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/result.h"

namespace penumbra {

enum class JointRole : unsigned char {
  Unknown,
  Hips,      // pelvis, the hierarchy's root joint
  Spine,     // spine, chest, abdomen
  Neck,
  Head,
  Clavicle,  // shoulder / collar bone
  UpperArm,
  Forearm,
  Hand,
  Finger,    // any finger or thumb segment
  Thigh,
  Calf,      // shin, lower leg, knee
  Foot,
  Toe,
  End,       // a leaf marker joint
};

// The role of the joint named `name`. Cost: O(name length). Thread-safe.
JointRole joint_role(std::string_view name);

// "forearm", "finger", ... ("unknown" for Unknown).
const char* to_string(JointRole role);

// The default limit of a role: the joint turns within +-limit radians about each axis of its
// bind frame (the axes of a bend are not known from a name, so the limit is per axis). Human
// ranges of motion, conservative: forearm 1.0, upper arm 0.9, calf 0.9, thigh 0.7, hand 0.6,
// finger 0.5, head 0.4, foot 0.4, neck 0.35, toe 0.3, spine 0.25, clavicle 0.25, hips 0.3; End 0;
// Unknown returns `unknown`.
float role_limit(JointRole role, float unknown);

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
