// Pose-AO runtime: PoseAOSystem, loading baked data, default components and the registration of
// the "pose-ao" baker (see pose_ao_system.h).
#include "penumbra/pose_ao/pose_ao_system.h"

#include <string>
#include <utility>
#include <vector>

#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

bool skinned_mesh(World& world, Entity e) {
  const Mesh* mesh = world.try_get<Mesh>(e);
  return mesh && mesh->data && world.has<Skin>(e) && !mesh->data->positions.empty() &&
         mesh->data->joints.size() == mesh->data->positions.size() &&
         mesh->data->weights.size() == mesh->data->positions.size();
}

}  // namespace

std::vector<Entity> pose_ao_meshes(World& world) {
  std::vector<Entity> out;
  for (Entity e : world.view<SkinnedPoseAO, WorldTransform>().sorted_entities())
    if (skinned_mesh(world, e)) out.push_back(e);
  return out;
}

std::size_t update_pose_ao(World& world, std::uint64_t since) {
  // The pools looked up per entity, found once.
  const ComponentPool<SkinPose> poses = world.pool<SkinPose>();
  const ComponentPool<SkinnedPoseAO> settings = world.pool<SkinnedPoseAO>();
  const ComponentPool<VertexAO> outputs = world.pool<VertexAO>();
  std::vector<Entity> due;
  world.view<SkinnedPoseAO, SkinPose>().each([&](Entity e, SkinnedPoseAO& s, SkinPose& pose) {
    if (!s.data || pose.joint_matrices.size() != s.data->joint_count) return;
    if (poses.changed_tick(e) > since || settings.changed_tick(e) > since || !outputs.contains(e)) due.push_back(e);
  });
  std::vector<float> features;
  for (Entity e : due) {
    const std::shared_ptr<const PoseAOData> data = settings.get(e).data;
    // Theta once per character, then the vectorised per-vertex loop.
    pose_features(data->joint_parents, poses.get(e).joint_matrices, features);
    VertexAO& out = world.has<VertexAO>(e) ? world.patch<VertexAO>(e) : world.add<VertexAO>(e);
    out.ao.resize(data->vertex_count);
    out.static_occluders = false;  // the character's own meshes: no baked source saw them
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

namespace {

Status attach_pose_ao(World& world, const BakeChunk& chunk, const EntityKeys& keys) {
  auto data = read_pose_ao_chunk(chunk);
  if (!data) return data.error();
  const std::string context = "chunk 'PSAO' (" + chunk.label + ")";
  auto e = keyed_owner<SkinnedPoseAO>(world, keys, data->key, context, "SkinnedPoseAO");
  if (!e) return e.error();
  const Mesh* mesh = world.try_get<Mesh>(*e);
  if (mesh == nullptr || !mesh->data || mesh->data->positions.size() != data->vertex_count)
    return make_error(ErrorCode::NotFound, context + ": entity '" + data->key + "' has no mesh of " +
                                               std::to_string(data->vertex_count) +
                                               " vertices in this World; re-bake the scene");
  world.patch<SkinnedPoseAO>(*e).data = std::make_shared<const PoseAOData>(std::move(*data));
  return {};
}

// Every skinned mesh, built-in or authored, gets pose-AO settings unless it brings its own.
Status add_defaults(World& world, Preset preset, bool) {
  add_default_pose_ao(world, preset);
  return {};
}

constexpr std::uint32_t kChunkTypes[] = {kPoseAOChunkType};

std::string explain_empty(World& world) {
  const std::size_t skinned = world.view<const Mesh, const Skin>().count();
  return "pose-ao bakes skinned meshes (a Mesh with a Skin and a SkinnedPoseAO) and this scene has " +
         std::to_string(skinned) + " skinned meshes, " +
         std::to_string(world.view<const SkinnedPoseAO>().count()) + " with a SkinnedPoseAO";
}

}  // namespace

namespace {

// The meshes with Skin below `root` (root included), depth first in Children order.
void skinned_meshes(const World& world, Entity root, std::vector<Entity>& out) {
  if (world.has<Skin>(root) && world.has<Mesh>(root)) out.push_back(root);
  if (const Children* c = world.try_get<Children>(root))
    for (Entity child : c->entities) skinned_meshes(world, child, out);
}

}  // namespace

std::size_t share_pose_ao(const World& from_world, Entity from, World& to_world, Entity to) {
  std::vector<Entity> sources, targets;
  skinned_meshes(from_world, from, sources);
  skinned_meshes(to_world, to, targets);
  std::size_t shared = 0;
  for (std::size_t i = 0; i < sources.size() && i < targets.size(); ++i) {
    const SkinnedPoseAO* source = from_world.try_get<SkinnedPoseAO>(sources[i]);
    if (!source || !source->data || !to_world.has<SkinnedPoseAO>(targets[i])) continue;
    const MeshData& mesh = *to_world.get<Mesh>(targets[i]).data;
    if (source->data->vertex_count != mesh.positions.size() ||
        source->data->joint_count != to_world.get<Skin>(targets[i]).joints.size())
      continue;
    to_world.patch<SkinnedPoseAO>(targets[i]).data = source->data;
    ++shared;
  }
  return shared;
}

const LightingModule& pose_ao_module() {
  static const ComponentInfo* const components[] = {&skinned_pose_ao_info()};
  static const LightingModule module{
      .name = "pose-ao",
      .description = "skinned pose-AO (per-vertex linear AO in the joint rotations, Kontkanen & Aila 2006)",
      .chunk_types = kChunkTypes,
      .components = components,
      .register_runtime = register_pose_ao_system,
      .chunk_key = leading_chunk_key,
      .attach = attach_pose_ao,
      .check = check_with<read_pose_ao_chunk>,
      .describe = describe_pose_ao_chunk,
      .add_defaults = add_defaults,
      .explain_empty = explain_empty,
  };
  return module;
}

std::size_t add_default_pose_ao(World& world, Preset preset) {
  std::vector<Entity> meshes;
  world.view<Mesh, Skin>().each([&](Entity e, Mesh&, Skin&) {
    if (!world.has<SkinnedPoseAO>(e) && skinned_mesh(world, e)) meshes.push_back(e);
  });
  for (Entity e : meshes) world.add<SkinnedPoseAO>(e, SkinnedPoseAO::preset(preset));
  return meshes.size();
}

}  // namespace penumbra
