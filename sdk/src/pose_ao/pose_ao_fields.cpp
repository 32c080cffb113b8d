// The field list of SkinnedPoseAO (fields.h). Per-joint ranges (joint_ranges) are a list, not a
// field: the bake hashes them itself.
#include "penumbra/lighting/field_list.h"
#include "penumbra/pose_ao/pose_ao.h"

namespace penumbra {

namespace {

using fields::member;
using T = FieldType;

constexpr std::string_view kPoseSources[] = {"auto", "clips", "roles", "uniform"};

const SkinnedPoseAO kDefaults{};
constexpr FieldInfo kFields[] = {
    member<&SkinnedPoseAO::reference_poses>({.name = "reference_poses", .type = T::Count, .min = 0, .max = 1e6,
                                             .unit = "poses", .help = "random training poses (100 draft, 1000 high)",
                                             .preset = true, .hashed = true, .speed = 1.0f}),
    member<&SkinnedPoseAO::clip_poses>({.name = "clip_poses", .type = T::Count, .min = 0, .max = 1e5,
                                        .unit = "poses", .help = "training frames from each clip", .preset = true,
                                        .hashed = true, .speed = 0.2f}),
    member<&SkinnedPoseAO::rays_per_vertex>({.name = "rays_per_vertex", .type = T::Count, .min = 1, .max = 1e6,
                                             .unit = "rays", .help = "per vertex per pose; use at least 16",
                                             .preset = true, .hashed = true, .speed = 0.5f}),
    member<&SkinnedPoseAO::locality>({.name = "locality", .type = T::Count, .min = 0, .max = kPoseAOMaxLocality,
                                      .unit = "joints", .help = "joints per vertex; 0 for the pose-averaged AO",
                                      .preset = true, .hashed = true, .speed = 0.05f}),
    member<&SkinnedPoseAO::clusters>({.name = "clusters", .type = T::Count, .min = 1, .max = kPoseAOMaxClusters,
                                      .unit = "models", .help = "local linear models per joint set; 1 for the "
                                                                 "thesis' single linear model (more: memory, accuracy)",
                                      .preset = true, .hashed = true, .speed = 0.05f}),
    member<&SkinnedPoseAO::lambda>({.name = "lambda", .type = T::Float, .min = 0, .max = 1e6,
                                    .help = "ridge strength per pose; 1e-3 is a good start", .hashed = true,
                                    .speed = 1e-4f}),
    member<&SkinnedPoseAO::pose_source>({.name = "pose_source", .type = T::Enum, .min = 0, .max = 3,
                                         .choices = kPoseSources,
                                         .help = "joint ranges: the clips, else the joints' roles by name, else "
                                                 "default_range (auto); or only one of them",
                                         .hashed = true}),
    member<&SkinnedPoseAO::joint_limits>({.name = "joint_limits", .type = T::Text, .min = 0, .max = 4096,
                                          .help = "limits by joint name: PATTERN=RADIANS, ... e.g. "
                                                  "LeftForeArm=1.2, *Spine*=0.3",
                                          .hashed = true}),
    member<&SkinnedPoseAO::ground>({.name = "ground", .type = T::Bool,
                                    .help = "trace a floor under the character (darkens the feet)",
                                    .hashed = true}),
    member<&SkinnedPoseAO::range_margin>({.name = "range_margin", .type = T::Float, .min = 0, .max = 100,
                                          .help = "clip ranges widened by this fraction on each side",
                                          .hashed = true, .speed = 0.005f}),
    member<&SkinnedPoseAO::default_range>({.name = "default_range", .type = T::Float, .min = 0, .max = 3.1416,
                                           .unit = "rad", .help = "+- range of every joint without clips",
                                           .hashed = true, .speed = 0.005f}),
};

}  // namespace

const ComponentInfo& skinned_pose_ao_info() {
  static const ComponentInfo info{.name = "SkinnedPoseAO",
                                  .fields = kFields,
                                  .defaults = &kDefaults,
                                  .find = fields::find_in<SkinnedPoseAO>,
                                  .patch = fields::patch_in<SkinnedPoseAO>,
                                  .copy = fields::copy_in<SkinnedPoseAO>,
                                  .set_preset_fields = fields::preset_fields<SkinnedPoseAO>,
                                  .emplace = fields::emplace_in<SkinnedPoseAO>,
                                  .erase = fields::erase_in<SkinnedPoseAO>,
                                  .on_mesh = true};
  return info;
}

}  // namespace penumbra
