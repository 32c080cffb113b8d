// The pose-AO baker (Kontkanen & Aila 2006; the thesis, section 4.2): reference poses, ray-traced
// per-vertex self-occlusion of each posed mesh, and the per-vertex ridge regression.
//
// Steps (bake_pose_ao runs them; the pose-ao bench calls them one by one to sweep the settings):
//   1. make_pose_rig: the skin's joint hierarchy, bind local transforms (from the inverse bind
//      matrices) and per-joint rotation ranges from the clips that animate the joints.
//   2. reference poses: random ones (each joint independently within its range) and clip frames.
//   3. PoseAOTracer: the posed mesh and the character's other meshes in an Embree BVH refitted
//      per pose; per vertex `rays_per_vertex` cosine-weighted rays from a scrambled Sobol' net,
//      AO = unoccluded fraction.
//   4. fit_pose_ao: per vertex ridge regression from the parameters of its joints to its AO.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "penumbra/core/pbake.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// A pose: the local transform of every skin joint.
using Pose = std::vector<Transform>;

// What the bake needs to know about a skinned mesh's skeleton.
struct PoseRig {
  std::vector<std::int32_t> parents;       // nearest ancestor among the skin's joints, -1 for a root
  std::vector<std::string> names;          // the joints' Names ("" for a joint without one)
  std::vector<glm::mat4> offsets;          // fixed: parent joint's frame (mesh frame for a root) -> the joint's parent node
  std::vector<glm::mat4> inverse_bind;
  Pose bind;                               // bind local transforms
  std::vector<glm::vec3> bind_positions;   // joint origins in the bind pose, mesh frame
  std::vector<JointRange> clip_ranges;     // rotation ranges seen in the clips (unwidened)
  std::vector<bool> animated;              // some clip rotates the joint
  std::vector<std::uint32_t> order;        // joints with parents before children
  // The clips that animate the skin's joints, and per clip its (channel, joint) pairs (channels on
  // other nodes are ignored).
  std::vector<const AnimationClip*> clips;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> clip_channels;

  std::size_t joint_count() const { return parents.size(); }
};

// Builds the rig of the skinned mesh `mesh_entity` (Mesh, Skin, WorldTransform; joints with
// Transforms and WorldTransforms: run the transform system first). The clips are those of every
// Animator whose clip targets a joint of the skin (sampled at 64 times per clip plus its keys for
// the ranges). Errors (InvalidInput) name `context`: no Skin, joints without transforms, an
// inverse bind matrix that is singular or not finite. Cost: O(joints x depth + clip samples).
// The rig points into the Animators' clips: keep the World's clips alive while using it.
Result<PoseRig> make_pose_rig(World& world, Entity mesh_entity, std::string_view context);

// A joint moves when its range is wider than this on some axis (radians, about 1.1 degrees); a
// pose space in which no joint moves is degenerate: every reference pose is the bind pose.
inline constexpr float kPoseMinJointRange = 0.02f;

// The pose space a bake samples, and where it came from.
struct PoseSpace {
  using Source = PoseSpaceSource;
  Source source = Source::Default;
  std::vector<JointRange> ranges;  // per skin joint
  std::size_t moving = 0;          // joints wider than kPoseMinJointRange
  std::size_t roles = 0;           // joints whose range came from a known role (Source::Roles)
  std::size_t anatomical = 0;      // of those, joints given their role's motion about the bone
                                   // (role_motion); the others turn +-role_limit on each axis
  std::size_t limited = 0;         // joints whose range joint_limits set
  std::vector<std::string> unmatched_limits;  // joint_limits patterns that match no joint
  std::size_t widest = 0;          // the joint of the widest range (any axis), and that width
  float widest_range = 0.0f;
  float clip_widest_range = 0.0f;  // the widest unwidened clip range (0 without clips)
};

// The pose space of `rig` under `settings` (above), joint_limits applied over the source's ranges
// (not over joint_ranges). With ranges in which no joint moves the space is degenerate too
// (moving == 0); bake_pose_ao refuses it. Precondition: validate_pose_ao passed (joint_limits
// parse). Cost: O(joints x limits).
PoseSpace pose_space(const PoseRig& rig, const SkinnedPoseAO& settings);

// Random pose `index` of the stream `seed`: joint j's local rotation is bind rotation x
// exp(r), r uniform in ranges[j] (Rng::stream(seed, index)); translations and scales stay at bind.
Pose random_pose(const PoseRig& rig, std::span<const JointRange> ranges, std::uint64_t seed, std::uint64_t index);
// The pose of clip `clip` (an index into rig.clips) at time t (clamped into the clip): its channels
// on the skin's joints over the bind pose.
Pose clip_pose(const PoseRig& rig, std::size_t clip, float t);

// Skinning matrices of a pose (what SkinPose::joint_matrices holds for it): M_j = X_j inverse_bind_j
// with X_j = X_parent offset_j local_j. Cost: O(joints).
std::vector<glm::mat4> skinning_matrices(const PoseRig& rig, const Pose& pose);

// Another skinned mesh of the same character (one skeleton, several meshes: a body and its
// armour), traced with the baked mesh so that each shadows the other.
struct PoseAOOccluder {
  std::shared_ptr<const MeshData> mesh;  // positions, indices, JOINTS_0/WEIGHTS_0 of its own skin
  // Per joint k of the occluder's skin: the joint j of the traced skin it is, and the matrix that
  // carries the occluder's bind vertices to the traced skin's bind pose for that joint,
  // inverse(inverse_bind_traced[j]) x inverse_bind_occluder[k] (the posed vertex is M_j x it).
  std::vector<std::uint32_t> joints;
  std::vector<glm::mat4> to_traced;
  glm::mat4 rigid{1.0f};  // its weightless vertices: its mesh frame -> the traced mesh's frame
};

// The other skinned meshes of `mesh_entity`'s character (character_meshes, scene/animation.h), as
// occluders. A mesh whose weights use a joint the
// traced skin lacks cannot be posed from its poses: it is left out, with a line in `notes`
// naming both meshes and the joint. Needs WorldTransforms (run the transform system). Cost:
// O(meshes x joints + their vertices).
std::vector<PoseAOOccluder> character_occluders(World& world, Entity mesh_entity,
                                                std::vector<std::string>* notes = nullptr);

// A ground plane under a character (SkinnedPoseAO::ground) as an occluder fixed in the traced
// mesh's frame: perpendicular to world up as `mesh_world` (the mesh's WorldTransform) carries it,
// through the lowest bind-pose vertex of `mesh` and `others` (the character's occluders), two
// character diagonals wide on each side. Cost: O(vertices).
PoseAOOccluder ground_occluder(const MeshData& mesh, std::span<const PoseAOOccluder> others,
                               const glm::mat4& mesh_world);

// Ray-traced self-occlusion of one skinned mesh in any pose, occluded by itself and by the
// character's other meshes (`occluders`, posed with it). Vertices with no skin weight follow the
// mesh (identity), as a rigid part of the character. Not thread-safe (trace() refits); the
// queries inside trace() run in parallel on `jobs`.
class PoseAOTracer {
 public:
  // Fails with InvalidInput naming `context` when the mesh has no normals, no joints/weights, or
  // a joint index >= joint_count with a non-zero weight, or an occluder's skinning does not fit
  // its joint map. Cost: one BVH build over the mesh and the occluders.
  static Result<PoseAOTracer> create(std::shared_ptr<const MeshData> mesh, std::size_t joint_count,
                                     std::string_view context, std::vector<PoseAOOccluder> occluders = {});
  PoseAOTracer(PoseAOTracer&&) noexcept;
  PoseAOTracer& operator=(PoseAOTracer&&) noexcept;
  ~PoseAOTracer();

  // AO of every vertex in the pose with skinning matrices `joint_matrices` (joint_count of them):
  // `rays` cosine-weighted rays per vertex from p + eps n (eps = 1e-4 x the bind bounds'
  // diagonal + 2e-5 |p|_max: scale-invariant), scrambled per vertex by `seed` (the same
  // directions for a vertex in every pose). Optionally the binomial standard error per vertex.
  // ao.size() == vertices. Bit-identical at any thread count. Fails with Cancelled, or
  // InvalidInput when the pose makes a vertex non-finite.
  // Cost: vertices x rays occlusion rays plus an O(vertices) refit.
  Status trace(std::span<const glm::mat4> joint_matrices, std::uint32_t rays, std::uint64_t seed, JobContext& jobs,
               std::span<float> ao, std::span<float> standard_error = {});

  std::size_t vertex_count() const;    // of the traced mesh
  std::size_t occluder_count() const;

 private:
  struct Impl;
  explicit PoseAOTracer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Reference data of a mesh: per pose its features and per-vertex AO.
struct PoseAOTraining {
  std::size_t vertex_count = 0;
  std::size_t joint_count = 0;
  std::vector<float> features;  // pose p: [p F, (p + 1) F), F = 9 joints
  std::vector<float> ao;        // pose p: [p V, (p + 1) V)
  std::vector<float> bind_ao;   // the bind pose (all skinning matrices identity)

  std::size_t poses() const { return vertex_count == 0 ? 0 : ao.size() / vertex_count; }
  // Appends one pose (traced by `tracer`). Cost: one trace().
  Status add_pose(PoseAOTracer& tracer, const PoseRig& rig, const Pose& pose, std::uint32_t rays,
                  std::uint64_t seed, JobContext& jobs);
};

// Fits the per-vertex linear models to the first `poses` poses of `training` (all when 0).
// Locality as SkinnedPoseAO::locality over `mesh`'s weights, the rig's hierarchy and the poses
// (a 10-coefficient fit per joint scores it); a joint whose features are constant (within 1e-5)
// over those poses is never selected; vertices of joint sets shared by fewer than 16 vertices
// join the set whose linear fit explains most of their AO among a few large sets and one pooled
// for their dominant joint (large groups evaluate fastest). When the poses are fewer than the
// coefficients (poses < 1 + 9 k) k is reduced to fit and a warning is logged and appended to
// `warnings`. Normal equations per joint set in double, Cholesky with a pivot floor (1e-9 of the
// trace), so rank-deficient data (a joint that never moves, collinear parameters, lambda = 0)
// gives finite, bounded coefficients. Each vertex is refitted a few times with the poses whose AO
// sits at 0 or 1 and whose prediction lies beyond it taken as fitted (the model is clamped where
// it is evaluated: censored regression). Per joint set the bind blend (PoseAOGroup) is the one
// of none and 0.001..0.3 x the poses' median squared distance from the bind pose that gives the
// least training error. Clusters (pose_ao.h, SkinnedPoseAO::clusters): per joint set k-means over
// the poses (seeded per joint set) in the metric of the set's linear model fitted to the same
// poses, the clusters' maps fitted jointly with their blend weights; 1, 2, 4, .. up to the count
// asked for (at most one per 3 x coefficients poses, a note in `warnings` when that caps it) are
// fitted to four fifths of the poses and the count whose error on the fifth left out is least (by
// 1 % at least over fewer) is refitted to all. The coefficients are rounded to IEEE halves
// (PoseAOGroup), what the chunk stores and the runtime reads. Deterministic (fixed summation order
// and seeds, any thread count). Errors: InvalidArgument when training has no pose. Cost: per joint
// set and cluster count K tried, about P C^2 (a pose's row holds one or two clusters' entries) +
// (K C)^3 / 6; per vertex about P C per count and ridge strength tried, and P C per strength for
// the metric's linear fit; plus P x 10 per candidate joint (the scores) and, per vertex of a rare
// set, P C for each of up to 17 sets it may join (each factorised once).
Result<PoseAOData> fit_pose_ao(const PoseAOTraining& training, const PoseRig& rig, const MeshData& mesh,
                               const SkinnedPoseAO& settings, std::size_t poses, JobContext& jobs,
                               std::vector<std::string>* warnings = nullptr, std::string_view context = "pose-AO");

// The whole bake of one skinned mesh entity: validate, rig, tracer, bind pose, reference poses
// (random with Rng::stream(seed, pose), then clip frames), fit. Reserves the training arrays in
// `budget` first (OutOfBudget suggests fewer poses). Progress stages "pose-ao poses" (one unit per
// vertex per pose) and "pose-ao fit". Bit-identical at any thread count.
Result<PoseAOData> bake_pose_ao(World& world, Entity mesh_entity, const SkinnedPoseAO& settings, std::uint64_t seed,
                                JobContext& jobs, MemoryBudget& budget, std::vector<std::string>* warnings = nullptr);

// Registers the "pose-ao" baker: one PSAO chunk per SkinnedPoseAO entity with Mesh and Skin, in
// entity order, keyed by entity key; the baked data, as read back from its chunk (16-bit
// coefficients), is attached to the components.
void register_pose_ao_baker(World& world);

}  // namespace penumbra
