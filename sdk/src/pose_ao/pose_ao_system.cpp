// Pose-AO runtime: PoseAOSystem, loading baked data, default components and the registration of
// the "poseao" baker (see pose_ao_system.h).
#include "penumbra/pose_ao/pose_ao_system.h"

#include <string>
#include <utility>

#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kChunkType = fourcc("PSAO");

bool skinned_mesh(World& world, Entity e) {
  const Mesh* mesh = world.try_get<Mesh>(e);
  return mesh && mesh->data && world.has<Skin>(e) && !mesh->data->positions.empty() &&
         mesh->data->joints.size() == mesh->data->positions.size() &&
         mesh->data->weights.size() == mesh->data->positions.size();
}

// The meshes to bake, in entity-index order.
std::vector<Entity> pose_ao_entities(World& world) {
  std::vector<Entity> out;
  for (Entity e : world.view<SkinnedPoseAO, WorldTransform>().sorted_entities())
    if (skinned_mesh(world, e)) out.push_back(e);
  return out;
}

}  // namespace

std::size_t update_pose_ao(World& world, std::uint64_t since) {
  std::vector<Entity> due;
  world.view<SkinnedPoseAO, SkinPose>().each([&](Entity e, SkinnedPoseAO& s, SkinPose& pose) {
    if (!s.data || pose.joint_matrices.size() != s.data->joint_count) return;
    if (world.changed_tick<SkinPose>(e) > since || world.changed_tick<SkinnedPoseAO>(e) > since ||
        !world.has<VertexAO>(e))
      due.push_back(e);
  });
  std::vector<float> features;
  for (Entity e : due) {
    const std::shared_ptr<const PoseAOData> data = world.get<SkinnedPoseAO>(e).data;
    // Theta once per character, then the vectorised per-vertex loop.
    pose_features(data->joint_parents, world.get<SkinPose>(e).joint_matrices, features);
    VertexAO& out = world.has<VertexAO>(e) ? world.patch<VertexAO>(e) : world.add<VertexAO>(e);
    out.ao.resize(data->vertex_count);
    evaluate_pose_ao(*data, features, out.ao);
  }
  return due.size();
}

void register_pose_ao_system(World& world) {
  SystemDesc desc;
  desc.name = "pose-ao";
  desc.phase = Phase::Lighting;
  desc.reads = {component_id<SkinPose>(), component_id<SkinnedPoseAO>()};
  desc.writes = {component_id<VertexAO>()};
  desc.run = [](World& w, const SystemContext& ctx) { update_pose_ao(w, ctx.last_run); };
  world.add_system(std::move(desc));
}

Status attach_pose_ao(World& world, const BakeFile& file) {
  for (const BakeChunk& chunk : file.chunks) {
    if (chunk.type != kChunkType) continue;
    auto data = read_pose_ao_chunk(chunk);
    if (!data) return data.error();
    const Entity e = world.find_entity(data->entity_index);
    const Mesh* mesh = world.has<SkinnedPoseAO>(e) ? world.try_get<Mesh>(e) : nullptr;
    if (mesh == nullptr || !mesh->data || mesh->data->positions.size() != data->vertex_count)
      return make_error(ErrorCode::NotFound, "chunk 'PSAO' (" + chunk.label + "): entity " +
                                                 std::to_string(data->entity_index) +
                                                 " has no SkinnedPoseAO on a mesh of " +
                                                 std::to_string(data->vertex_count) +
                                                 " vertices in this World; re-bake the scene");
    world.patch<SkinnedPoseAO>(e).data = std::make_shared<const PoseAOData>(std::move(*data));
  }
  return {};
}

std::size_t add_default_pose_ao(World& world, Preset preset) {
  std::vector<Entity> meshes;
  world.view<Mesh, Skin>().each([&](Entity e, Mesh&, Skin&) {
    if (!world.has<SkinnedPoseAO>(e) && skinned_mesh(world, e)) meshes.push_back(e);
  });
  for (Entity e : meshes) world.add<SkinnedPoseAO>(e, SkinnedPoseAO::preset(preset));
  return meshes.size();
}

namespace {

Result<std::vector<BakeChunk>> bake_all(BakeInputs& in) {
  std::vector<BakeChunk> chunks;
  for (Entity e : pose_ao_entities(in.world)) {
    const SkinnedPoseAO settings = in.world.get<SkinnedPoseAO>(e);
    auto data = bake_pose_ao(in.world, e, settings, in.settings.seed, in.jobs, in.budget);
    if (!data) return data.error();
    chunks.push_back(write_pose_ao_chunk(*data));
    // Attach what the file holds (16-bit coefficients), so the runtime matches a reload.
    auto stored = read_pose_ao_chunk(chunks.back());
    if (!stored) return stored.error();
    in.world.patch<SkinnedPoseAO>(e).data = std::make_shared<const PoseAOData>(std::move(*stored));
  }
  return chunks;
}

void hash_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kPoseAOChunkVersion);
  for (Entity e : pose_ao_entities(world)) {
    const SkinnedPoseAO& s = world.get<SkinnedPoseAO>(e);
    h.add(e.index);
    h.add(s.reference_poses);
    h.add(s.clip_poses);
    h.add(s.rays_per_vertex);
    h.add(s.locality);
    h.add(s.lambda);
    h.add(s.range_margin);
    h.add(s.default_range);
    h.add(s.joint_ranges);
    const Skin& skin = world.get<Skin>(e);
    h.add(skin.inverse_bind);
    for (Entity j : skin.joints)
      if (const Transform* t = world.alive(j) ? world.try_get<Transform>(j) : nullptr) h.add(t->matrix());
    // The clips that drive the ranges: their keys.
    world.view<Animator>().each([&](Entity, Animator& a) {
      if (!a.clips) return;
      for (const AnimationClip& clip : *a.clips)
        for (const AnimationChannel& ch : clip.channels) {
          h.add(ch.times);
          h.add(ch.values);
        }
    });
  }
}

}  // namespace

void register_pose_ao(World& world) {
  Baker b;
  b.name = "poseao";
  b.description = "skinned pose-AO (per-vertex linear AO in the joint rotations, Kontkanen & Aila 2006)";
  b.stages = 2;  // per mesh: poses, fit
  b.hash_inputs = hash_inputs;
  b.bake = bake_all;
  b.describe = describe_pose_ao_chunk;
  world.resource<BakerRegistry>().add(std::move(b));
  register_pose_ao_system(world);
}

}  // namespace penumbra
