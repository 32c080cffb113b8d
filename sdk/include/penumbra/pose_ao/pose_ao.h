// Skinned pose-AO (P5): ambient occlusion for animated characters in any pose, after Kontkanen &
// Aila 2006, "Ambient Occlusion for Animated Characters" (EGSR; the thesis, section 4.2).
//
// Per vertex v a linear map from the pose parameters theta to AO is learnt from ray-traced
// reference poses: A_v(theta) = clamp(t_v . theta_local(v), 0, 1), where theta_local(v) =
// [1, f_j1 .. f_jk] holds the parameters of the k <= kPoseAOMaxLocality joints that matter for v
// (its locality). The bake is in pose_ao_baker.h, the per-frame system in pose_ao_system.h.
//
// Clustered local models (after Kirk & Arikan 2007, "Real-time ambient occlusion for dynamic
// character skins"): AO is far from linear in the pose over a wide pose space (a limb swings into
// a vertex's hemisphere and out again), so the vertices that share a joint set may instead have a
// linear map per cluster of poses, the clusters' centres found by k-means over the training poses'
// theta_local in a metric that scales each parameter by how much the set's AO depends on it (the
// RMS over its vertices of the parameter's coefficient in the set's linear model): the clusters
// split the poses where the AO changes, not where the poses spread most (joints that move far and
// shade nothing). A pose takes the map of its nearest centre; within a band of the Voronoi boundary
// it blends the maps of the centres about as near (pose_ao_cluster_weights), so AO stays
// continuous as the pose moves while most frames evaluate one map per vertex.
//
// Pose parameters (the 9-entry choice of the thesis' reconstruction, algorithms.md P5). With M_j
// the skinning matrix of joint j (SkinPose::joint_matrices, the identity in the bind pose) and
// R_j the rotation of its upper 3x3 (columns normalised),
//   f_j = R_p^T R_j - I   (9 numbers, column-major), p = the joint's parent joint,
//   f_j = R_j - I         for a root joint (no parent among the skin's joints).
// R_p^T R_j is the joint's local rotation relative to its bind local rotation, expressed in the
// parent's bind frame: a fixed change of basis of the "R R_bind^T - I" of the joint's local
// rotation, so the linear model is the same, and it can be computed from SkinPose alone (no
// hierarchy walk at runtime). Zero in the bind pose; bounded by 2 per entry in any pose.
// Translations (a hip bob, root motion) are not parameters: self-occlusion ignores root motion.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/isa.h"
#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"

namespace penumbra {

inline constexpr std::uint32_t kPoseAOMaxLocality = 4;    // joints per vertex, at most
inline constexpr std::uint32_t kPoseAOMaxClusters = 16;   // local models per joint set, at most
inline constexpr std::uint32_t kPoseAOBlock = 32;         // vertices per block of coefficients (PoseAOGroup)
inline constexpr std::uint32_t kPoseFeaturesPerJoint = 9;  // entries of R_p^T R_j - I
// Coefficients of a vertex whose locality has `joints` joints: the bias plus 9 per joint.
constexpr std::uint32_t pose_ao_coefficients(std::uint32_t joints) { return 1 + kPoseFeaturesPerJoint * joints; }

struct PoseAOData;

// The range of a joint's local rotation, relative to its bind local rotation, as a rotation
// vector r (axis x angle, radians): each component in [min, max], about the axes `axes` turns the
// joint's bind local frame's onto (the rotation is axes exp(r) axes^-1; identity: the frame's own).
struct JointRange {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
  glm::quat axes{1.0f, 0.0f, 0.0f, 0.0f};  // unit
};

// Authoring component, on an entity with Mesh (joints + weights) and Skin.
struct SkinnedPoseAO {
  // Random reference poses: each joint's rotation drawn independently and uniformly within its
  // range, so that the effects of different joints are not confounded (the thesis uses ~1000).
  // Clustered models keep gaining from more where the AO is far from linear in the pose (the
  // pose-ao bench sweeps to 8000). The fit holds poses x vertices floats of training AO.
  std::uint32_t reference_poses = 250;
  // Frames of each animation clip that targets the skin's joints, added to the reference poses
  // (uniform in time, at the middle of each of clip_poses equal intervals).
  std::uint32_t clip_poses = 16;
  // Cosine-weighted rays per vertex per pose (scrambled Sobol', the same scramble in every pose so
  // that pose-to-pose differences are not swamped by noise).
  std::uint32_t rays_per_vertex = 64;
  // Joints per vertex (0..kPoseAOMaxLocality): its skinning joints by weight, then the joints
  // whose parameters alone explain most of its AO over the reference poses; joints that never
  // move, or have no geometry on the vertex's other side (roots), are skipped. 0 gives the
  // pose-averaged AO.
  std::uint32_t locality = 4;
  // Ridge strength per pose: t_v minimises sum_p (t . theta_p - a_p)^2 + lambda P |t_1..|^2 over the
  // P poses (the bias t_0 is not regularised; with clusters, P is each cluster's weight in the poses).
  // The strongest the fit tries: it takes lambda, lambda / 10 or lambda / 100 for the character,
  // whichever fits poses held out of the fit best (0 tries 0 alone).
  float lambda = 1e-3f;
  // Local linear models per joint set, at most (1..kPoseAOMaxClusters; see the top of this file):
  // 1 is the thesis' single linear model. The bake uses fewer where the poses are too few for them
  // (one cluster per 3 x coefficients poses), and per joint set only as many as cut the error on
  // poses held out of the fit. Memory grows with the clusters used; the per-frame cost 1.1-1.5x the
  // linear model's (the blends near cluster boundaries; pose-ao bench).
  std::uint32_t clusters = 8;
  // Where the random poses' joint ranges come from when joint_ranges is empty:
  //   Auto     the clips when they turn some joint (kPoseMinJointRange); else the joints' roles
  //            when their names give any (joint_roles.h); else +-default_range on every joint.
  //   Clips    the clips (clips that barely move: +-default_range on the joints they animate).
  //   Roles    the joints' roles by name, whatever the clips hold: each joint within its role's
  //            motion about its bone (role_motion: a knee bends backward only), or +-role_limit(role)
  //            on each axis where that cannot be placed (+-default_range for no known role).
  //   Uniform  +-default_range on every joint.
  enum class PoseSource : std::uint8_t { Auto, Clips, Roles, Uniform };
  PoseSource pose_source = PoseSource::Auto;
  // Ranges from the clips are widened by this fraction of their width on each side (a joint whose
  // clip range is empty stays fixed).
  float range_margin = 0.25f;
  // Joints with no range from the clips or a role: +-default_range radians about each axis.
  float default_range = 0.5f;
  // Limits by joint name over the ranges above, as text (settable in the glTF extension and the
  // editor): "PATTERN=RADIANS" entries, e.g. "LeftForeArm=1.2, *Spine*=0.3, *Hand*=0"
  // (joint_roles.h, parse_joint_limits): each matching joint turns within +-limit on each axis.
  std::string joint_limits;
  // Ranges set by hand, one per skin joint (empty: from pose_source and joint_limits as above).
  std::vector<JointRange> joint_ranges;
  // Trace a ground plane under the character with it: contact with the floor darkens the feet.
  // The plane is perpendicular to world up (+Y through the mesh's world transform) at the lowest
  // bind-pose vertex of the character's meshes, and does not move with the poses; the root joints
  // then stay at their bind rotation (a turned root would tilt the character against the floor).
  // A pose that lowers a foot below the plane traces it as buried: keep foot ranges modest.
  bool ground = false;

  // The baked data (set by the baker or attach_bake(), penumbra/runtime.h); null until baked.
  std::shared_ptr<const PoseAOData> data;

  // Quality presets: draft 100 random poses, 32 rays, 3 joints, 1 cluster; medium 250 poses, 64
  // rays, 4 joints, 2 clusters; high 1000 poses, 128 rays, 4 joints, 8 clusters. Each adds 16
  // frames per clip.
  static SkinnedPoseAO preset(Preset preset);
};

// Checks the settings against a skin of `joint_count` joints. InvalidArgument naming `context`
// (e.g. "pose-AO 'body' (entity 12)"), the field and the fix: zero poses in total, zero rays,
// locality above kPoseAOMaxLocality, a negative or non-finite lambda, margin or default range,
// joint_ranges of the wrong length, with min > max, non-finite bounds or axes not a unit
// quaternion. O(joints). Thread-safe.
Status validate_pose_ao(const SkinnedPoseAO& settings, std::size_t joint_count, std::string_view context);

// Vertices that share a joint set share one factorisation at bake and one parameter gather at
// runtime. Their coefficients are IEEE 16-bit halves in blocks of kPoseAOBlock vertices:
// coefficient c of cluster m of the group's vertex i = b kPoseAOBlock + l is
// coefficients[coefficient_index(m, c, i)] = coefficients[coefficient_offset + ((m blocks() + b)
// coefficient_count() + c) kPoseAOBlock + l], the last block's lanes past `count` zero. A cluster's
// coefficients are then one contiguous run that the runtime reads front to back, a block's worth
// of each coefficient at a time. With D = coefficient_count() - 1, a clustered group's entries in
// centers are the metric's scales s (D of them, at center_offset), then cluster m's centre at
// center_offset + (m + 1) D, in the space of s times theta_local without its leading 1 (entry by
// entry; see the top of this file).
//
// Near the bind pose a group blends towards the bind-pose AO, which the bake traced:
// with d^2 = |f_j1 .. f_jk|^2 (zero in the bind pose), ao = bind + w (clamp(t . theta) - bind),
// w = min(1, d^2 / bind_blend): a pose at least sqrt(bind_blend) from the bind pose gets the linear
// model alone, at no cost. bind_blend = 0 is the linear model alone everywhere; the bake picks it
// per group from the training poses (a one-frame clip makes the bind pose matter).
struct PoseAOGroup {
  std::array<std::uint16_t, kPoseAOMaxLocality> joints{};  // skin joint indices, ascending
  std::uint32_t joint_count = 0;
  std::uint32_t first = 0;   // into PoseAOData::vertex_order
  std::uint32_t count = 0;   // vertices
  std::uint64_t coefficient_offset = 0;
  float bind_blend = 0.0f;   // >= 0, finite
  std::uint32_t cluster_count = 1;  // 1..kPoseAOMaxClusters
  std::uint64_t center_offset = 0;  // into PoseAOData::centers
  float cluster_band = 0.0f;        // pose_ao_cluster_weights; >= 0, finite
  std::uint32_t coefficient_count() const { return pose_ao_coefficients(joint_count); }
  std::uint32_t blocks() const { return (count + kPoseAOBlock - 1) / kPoseAOBlock; }
  // Halves the group holds: cluster_count x blocks() x coefficient_count() x kPoseAOBlock.
  std::uint64_t coefficient_span() const {
    return std::uint64_t{cluster_count} * blocks() * coefficient_count() * kPoseAOBlock;
  }
  std::uint64_t coefficient_index(std::uint32_t m, std::uint32_t c, std::uint32_t i) const {
    return coefficient_offset +
           ((std::uint64_t{m} * blocks() + i / kPoseAOBlock) * coefficient_count() + c) * kPoseAOBlock +
           i % kPoseAOBlock;
  }
};

// Blend weights of a joint set's clusters at the pose `theta` (theta_local without its leading 1,
// scaled into the clusters' metric, `dims` entries): with d_m the squared distance to centre m and
// d the least of them, w_m = s((d_m - d) / band), s(x) = 1 - 3x^2 + 2x^3 below 1 and 0 beyond,
// normalised to sum 1. Each w_m is continuous in theta (d_m - d is zero on the nearest centre and
// changes continuously when the nearest changes), so is the blended AO; band 0 takes the nearest
// centre alone (ties: the lower index). Writes `clusters` weights, returns how many are non-zero.
// Isa::Best sums the squared distances eight lanes wide where the CPU has AVX2 and FMA (they may
// differ from Portable's in the last bits); the bake uses Portable, so that what it writes does
// not depend on the CPU. Cost: clusters x dims multiply-adds. Thread-safe.
std::uint32_t pose_ao_cluster_weights(const float* centers, std::uint32_t clusters, std::uint32_t dims,
                                      const float* theta, float band, float* weights, Isa isa = Isa::Portable);

// Where a bake's pose space came from (pose_space in pose_ao_baker.h).
enum class PoseSpaceSource : std::uint8_t {
  JointRanges,      // SkinnedPoseAO::joint_ranges
  Clips,            // the clip ranges widened by range_margin (joints no clip rotates stay fixed)
  Default,          // no clip: +-default_range on every axis of every joint
  DegenerateClips,  // the clips move no joint (e.g. two keys 0.067 s apart): +-default_range on
                    // every joint they animate (every joint when they rotate none), as without clips
  Roles,            // the joints' roles by name (joint_roles.h), +-default_range for unknown roles
  DegenerateClipsRoles,  // the clips move no joint, so the ranges come from the joints' roles
};
// The clips of the file were found to move no joint (a warning to repeat in reports).
constexpr bool degenerate_clips(PoseSpaceSource s) {
  return s == PoseSpaceSource::DegenerateClips || s == PoseSpaceSource::DegenerateClipsRoles;
}
// "the clips", "joint_ranges", ... for reports.
const char* to_string(PoseSpaceSource source);

// Baked data of one skinned mesh.
struct PoseAOData {
  std::string key;  // the mesh entity's stable key (scene/entity_key.h)
  std::uint32_t vertex_count = 0;
  std::uint32_t joint_count = 0;
  std::vector<std::int32_t> joint_parents;  // per skin joint: its parent joint, -1 for a root
  std::vector<PoseAOGroup> groups;          // in the order of their joint sets
  std::vector<std::uint32_t> vertex_order;  // group vertices, concatenated: mesh vertex indices
  std::vector<std::uint16_t> coefficients;  // IEEE halves, see PoseAOGroup
  std::vector<float> centers;               // see PoseAOGroup
  // Baselines by the same bake: AO of the bind pose and AO averaged over the reference poses.
  std::vector<float> bind_ao, mean_ao;

  // How it was baked (for reports).
  std::uint32_t poses = 0;             // reference poses fitted (random + clip frames)
  std::uint32_t rays_per_vertex = 0;
  std::uint32_t requested_locality = 0;
  std::uint32_t locality = 0;          // < requested when there were fewer poses than coefficients
  std::uint32_t requested_clusters = 1;
  std::uint32_t clusters = 1;          // the most of any joint set (< requested: too few poses)
  float lambda = 0.0f;                 // the ridge strength the fit chose (SkinnedPoseAO::lambda)
  float training_rmse = 0.0f;          // of the clamped model over the reference poses
  PoseSpaceSource pose_space = PoseSpaceSource::Default;  // where the random poses' ranges came from
  std::uint32_t moving_joints = 0;     // joints whose range exceeds kPoseMinJointRange (pose_ao_baker.h)
  float widest_range = 0.0f;           // the widest joint range (radians, any axis)

  std::size_t feature_count() const { return std::size_t{joint_count} * kPoseFeaturesPerJoint; }
  // Coefficient c of cluster m of group g's vertex i, as a float.
  float coefficient(const PoseAOGroup& g, std::uint32_t m, std::uint32_t c, std::uint32_t i) const;
  std::uint64_t bytes() const;  // memory held by the arrays
  // Stored bytes per vertex: its coefficients as 16-bit halves plus its 4-byte vertex index, with
  // the group table spread over the vertices.
  double bytes_per_vertex() const;
};

// The pose parameters f (9 per joint, joint-major; see above) of a pose given by its skinning
// matrices. parents[j] < j is not required; -1 marks a root. Precondition: parents.size() ==
// joint_matrices.size(). out is resized to 9 x joints. Cost: ~60 flops per joint. Thread-safe.
void pose_features(std::span<const std::int32_t> parents, std::span<const glm::mat4> joint_matrices,
                   std::vector<float>& out);

// AO of every vertex for pose features `features` (from pose_features): ao[v] = clamp(sum_m w_m
// t_v,m . theta_local(v), 0, 1) over its group's clusters (one term without clusters), blended
// towards bind_ao near the bind pose (PoseAOGroup), group by group, a block of vertices at a time
// (eight lanes with AVX2, FMA and F16C where the CPU has them and `isa` is Best, else the portable
// loop; the fused multiply-adds may move the last bit). Preconditions: features.size() ==
// data.feature_count(), ao.size() == data.vertex_count. Cost: about (1 + 9 k) multiply-adds per
// vertex and blended cluster, reading 2 (1 + 9 k) bytes of coefficients (the pose-ao bench
// measures the ns per vertex of both loops: the portable one, which converts the halves in
// software, took 4-6x the wide one's time). Thread-safe (writes only `ao`).
void evaluate_pose_ao(const PoseAOData& data, std::span<const float> features, std::span<float> ao,
                      Isa isa = Isa::Best);

// The "PSAO" chunk of one mesh (label "pose-ao:<key>"): the coefficients' halves without the
// blocks' padding, cluster by cluster and coefficient by coefficient over each group's vertices
// (the groups' offsets count those; the reader lays them out in blocks again), the rest as
// written. The reader checks the version, every size and index, that the groups
// partition the vertices, finiteness and [0, 1] baselines, naming the chunk in its errors.
inline constexpr std::uint32_t kPoseAOChunkType = fourcc("PSAO");
inline constexpr std::uint32_t kPoseAOChunkVersion = 6;  // 6: the clusters' metric
BakeChunk write_pose_ao_chunk(const PoseAOData& data);
Result<PoseAOData> read_pose_ao_chunk(const BakeChunk& chunk);

// Lines for `penumbra info`: vertices, joints, groups, poses, rays, locality, lambda, training
// RMSE, bytes per vertex (and a warning when locality was reduced).
std::vector<std::string> describe_pose_ao_chunk(const BakeChunk& chunk);

// The field list (lighting/fields.h) of SkinnedPoseAO.
const ComponentInfo& skinned_pose_ao_info();

}  // namespace penumbra
