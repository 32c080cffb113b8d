// The vertex-AO baker and the bake driver: closed form inside the furnace, determinism, input
// hashing, chunk round trip and damage, errors for unknown bakers and budgets.
#include "penumbra/vertex_ao/vertex_ao_baker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/vertex_ao/vertex_ao.h"

namespace penumbra {
namespace {

// A World holding a built-in scene, with the vertex-AO baker registered and transforms current.
World scene_world(std::string_view name) {
  World world;
  register_scene_systems(world);
  register_vertex_ao_baker(world);
  EXPECT_TRUE(load_builtin(world, name).ok());
  world.update(0.0);
  return world;
}

Result<BakeResult> bake(World& world, const BakeSettings& settings, unsigned threads) {
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  return bake_world(world, {"vertex-ao"}, settings, jobs);
}

// A draft vertex-AO bake of `world` on two threads.
Result<BakeResult> draft_bake(World& world) {
  BakeSettings settings;
  settings.preset = Preset::Draft;
  return bake(world, settings, 2);
}

TEST(VertexAo, FurnaceMatchesTheChordClosedForm) {
  // Inside a sphere of radius R a ray leaving the wall at angle theta to the normal travels the
  // chord 2 R cos(theta). It is unoccluded within D when cos(theta) > D / (2R), so for cosine-
  // distributed rays A = 1 - (D / 2R)^2.
  World world = scene_world("furnace");
  BakeSettings settings;
  settings.preset = Preset::High;
  auto result = bake(world, settings, 2);
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result->file.chunks.size(), 1u);
  auto data = read_vertex_ao_chunk(result->file.chunks[0]);
  ASSERT_TRUE(data.ok()) << data.error().message;
  ASSERT_EQ(data->entries.size(), 1u);
  const float d = data->max_distance, r = kFurnaceRadius;
  const double expected = 1.0 - double(d / (2.0f * r)) * double(d / (2.0f * r));
  double sum = 0.0;
  for (float a : data->entries[0].ao) sum += a;
  const double n = double(data->entries[0].ao.size());
  // Per vertex the binomial std error is sqrt(A (1 - A) / rays); the mean over n vertices has
  // that / sqrt(n). At the preset's distance (D = 0.17 R) only rays within 5 degrees of the
  // wall are stopped, and there the tessellation (5,120 flat faces, a slight corner at every
  // vertex) stops ~10 % more of them than the sphere: a 15 % allowance on the occlusion
  // 1 - A = (D / 2R)^2, which still tells D from 0.8 D or 1.2 D.
  const double std_error = std::sqrt(expected * (1.0 - expected) / double(data->rays) / n);
  EXPECT_NEAR(1.0 - sum / n, 1.0 - expected, 3.0 * std_error + 0.15 * (1.0 - expected));
  // The preset's distance follows the scene: 5 % of the diagonal of the sphere's bounds.
  EXPECT_NEAR(d, kVertexAoDistanceFraction * 2.0f * std::sqrt(3.0f) * r, 0.01f * d);
}

// Skinned meshes bake in their bind pose, occluded by their character's meshes: the humanoid's
// body is shadowed by its gear, and agrees with the pose-AO tracer's bind pose (another path to
// the same integral).
TEST(VertexAo, SkinnedMeshesBakeInTheirBindPoseWithTheirCharacter) {
  World world = scene_world("humanoid");
  auto result = draft_bake(world);
  ASSERT_TRUE(result) << result.error().message;
  ASSERT_EQ(result->file.chunks.size(), 1u);
  auto data = read_vertex_ao_chunk(result->file.chunks[0]);
  ASSERT_TRUE(data) << data.error().message;
  ASSERT_EQ(data->entries.size(), 2u);  // body, gear
  Entity body;
  world.each<Name>([&](Entity e, Name& n) {
    if (n.value == "body") body = e;
  });
  const MeshData& mesh = *world.get<Mesh>(body).data;
  const VertexAoData::Entry& entry = data->entries[0];
  ASSERT_EQ(entry.ao.size(), mesh.positions.size());
  double under_pad = 0.0;
  std::size_t n = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::vec3 p = mesh.positions[v];
    if (p.x > 19.0f && p.x < 27.0f && p.y > 148.0f && mesh.normals[v].y > 0.7f) {
      under_pad += entry.ao[v];
      ++n;
    }
  }
  ASSERT_GT(n, 10u);
  EXPECT_LT(under_pad / double(n), 0.45);

  auto rig = make_pose_rig(world, body, "body");
  ASSERT_TRUE(rig) << rig.error().message;
  auto tracer =
      PoseAOTracer::create(world.get<Mesh>(body).data, rig->joint_count(), "body", character_occluders(world, body));
  ASSERT_TRUE(tracer) << tracer.error().message;
  JobContext jobs;
  std::vector<float> reference(mesh.positions.size());
  ASSERT_TRUE(tracer->trace(std::vector<glm::mat4>(rig->joint_count(), glm::mat4(1.0f)), 256, 3, jobs, reference));
  double bias = 0.0, mean_abs = 0.0;
  for (std::size_t v = 0; v < reference.size(); ++v) {
    bias += entry.ao[v] - reference[v];
    mean_abs += std::abs(entry.ao[v] - reference[v]);
  }
  bias /= double(reference.size());
  mean_abs /= double(reference.size());
  // 64 rays a vertex against 256: a standard error of at most 0.07 a vertex, 0.02 on average.
  EXPECT_LT(std::abs(bias), 0.01);
  EXPECT_LT(mean_abs, 0.04);

  // Attached, a character's AO counts in its lighting: its occluders are its own meshes, which no
  // baked source saw (VertexAO::static_occluders false; a static mesh's is true).
  ASSERT_TRUE(attach_bake(world, result->file));
  ASSERT_TRUE(world.has<VertexAO>(body));
  EXPECT_FALSE(world.get<VertexAO>(body).static_occluders);
  World cornell = scene_world("cornell");
  auto static_bake = draft_bake(cornell);
  ASSERT_TRUE(static_bake && attach_bake(cornell, static_bake->file));
  bool any = false;
  cornell.each<VertexAO>([&](Entity, VertexAO& ao) {
    EXPECT_TRUE(ao.static_occluders);
    any = true;
  });
  EXPECT_TRUE(any);
}

// The default distance scales with the scene: the same fraction of the static bounds' diagonal in
// the Cornell box (0.55 m) and the courtyard (20 m); an explicit one is kept; degenerate scenes 1 m.
TEST(VertexAo, DistanceFollowsTheSceneScale) {
  for (const char* name : {"cornell", "courtyard"}) {
    World world = scene_world(name);
    RaySceneOptions options;
    options.include_dynamic = false;
    auto rays = RayScene::build(world, options);
    ASSERT_TRUE(rays.ok());
    const float diagonal = glm::length(rays->bounds_max() - rays->bounds_min());
    auto result = draft_bake(world);
    ASSERT_TRUE(result.ok()) << result.error().message;
    auto data = read_vertex_ao_chunk(result->file.chunks[0]);
    ASSERT_TRUE(data.ok()) << data.error().message;
    EXPECT_FLOAT_EQ(data->max_distance, kVertexAoDistanceFraction * diagonal) << name;
  }
  VertexAoSettings explicit_distance;
  explicit_distance.max_distance = 2.5f;
  EXPECT_EQ(vertex_ao_distance(explicit_distance, 100.0f), 2.5f);
  EXPECT_EQ(vertex_ao_distance({}, 0.0f), 1.0f);
  EXPECT_EQ(vertex_ao_distance({}, std::nanf("")), 1.0f);
  EXPECT_EQ(vertex_ao_distance({}, -std::numeric_limits<float>::infinity()), 1.0f);
}

TEST(VertexAo, BitIdenticalAtOneAndTwoThreadsAndSeedMatters) {
  World world = scene_world("courtyard");
  BakeSettings settings;
  settings.preset = Preset::Draft;
  settings.seed = 11;
  auto one = bake(world, settings, 1);
  auto two = bake(world, settings, 2);
  ASSERT_TRUE(one.ok() && two.ok());
  EXPECT_EQ(one->file.chunks[0].payload, two->file.chunks[0].payload);
  EXPECT_EQ(one->file.input_hash, two->file.input_hash);
  settings.seed = 12;
  auto other = bake(world, settings, 2);
  ASSERT_TRUE(other.ok());
  EXPECT_NE(one->file.chunks[0].payload, other->file.chunks[0].payload);
  EXPECT_NE(one->file.input_hash, other->file.input_hash);
}

TEST(VertexAo, InputHashFollowsTheSceneAndTheSettings) {
  World world = scene_world("cornell");
  BakeSettings settings;
  const std::uint64_t base = bake_input_hash(world, {}, settings);
  EXPECT_EQ(base, bake_input_hash(world, {}, settings));
  settings.preset = Preset::High;
  EXPECT_NE(base, bake_input_hash(world, {}, settings));
  settings.preset = Preset::Medium;
  // Moving a light changes the inputs.
  world.each<Light, Transform>([&](Entity e, Light&, Transform&) { world.patch<Transform>(e).translation.x += 0.01f; });
  world.update(0.0);
  EXPECT_NE(base, bake_input_hash(world, {}, settings));
}

TEST(VertexAo, ChunkRoundTripsAndRejectsDamage) {
  VertexAoData data;
  data.max_distance = 2.0f;
  data.rays = 64;
  data.entries.push_back({"walls/north", {0.0f, 0.5f, 1.0f}});
  const BakeChunk chunk = write_vertex_ao_chunk(data);
  auto back = read_vertex_ao_chunk(chunk);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->entries[0].key, "walls/north");
  EXPECT_EQ(back->entries[0].ao, data.entries[0].ao);

  BakeChunk short_chunk = chunk;
  short_chunk.payload.resize(chunk.payload.size() - 2);
  auto truncated = read_vertex_ao_chunk(short_chunk);
  ASSERT_FALSE(truncated.ok());
  EXPECT_NE(truncated.error().message.find("VXAO"), std::string::npos);

  VertexAoData bad = data;
  bad.entries[0].ao[1] = 1.5f;
  auto out_of_range = read_vertex_ao_chunk(write_vertex_ao_chunk(bad));
  ASSERT_FALSE(out_of_range.ok());
  EXPECT_NE(out_of_range.error().message.find("vertex 1"), std::string::npos);

  for (float distance : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -1.0f}) {
    VertexAoData odd = data;
    odd.max_distance = distance;
    auto refused = read_vertex_ao_chunk(write_vertex_ao_chunk(odd));
    ASSERT_FALSE(refused.ok()) << distance;
    EXPECT_NE(refused.error().message.find("max distance"), std::string::npos) << refused.error().message;
  }

  BakeChunk newer = chunk;
  newer.version = kVertexAoChunkVersion + 1;
  auto unsupported = read_vertex_ao_chunk(newer);
  ASSERT_FALSE(unsupported.ok());
  EXPECT_EQ(unsupported.error().code, ErrorCode::Unsupported);
}

// The baked values reach the entities as VertexAO, one per vertex of their mesh, found by their
// keys: a World built in another order (every index shifted) gets the same values on the same
// meshes. A key that matches nothing, or a mesh of another size, is a NotFound naming the key.
TEST(VertexAo, AttachFindsTheBakedEntitiesByKeyWhateverTheirIndex) {
  World world = scene_world("courtyard");
  auto result = draft_bake(world);
  ASSERT_TRUE(result.ok()) << result.error().message;
  auto data = read_vertex_ao_chunk(result->file.chunks[0]);
  ASSERT_TRUE(data.ok());
  ASSERT_GT(data->entries.size(), 3u);

  World shifted;
  for (int i = 0; i < 7; ++i) shifted.create();
  register_scene_systems(shifted);
  ASSERT_TRUE(load_builtin(shifted, "courtyard").ok());
  shifted.update(0.0);
  ASSERT_TRUE(attach_bake(shifted, result->file).ok());
  const EntityKeys keys = EntityKeys::build(shifted);
  for (const auto& entry : data->entries) {
    auto e = keys.find(entry.key, "test");
    ASSERT_TRUE(e.ok()) << e.error().message;
    ASSERT_TRUE(shifted.has<VertexAO>(*e)) << entry.key;
    EXPECT_EQ(shifted.get<VertexAO>(*e).ao, entry.ao) << entry.key;
    EXPECT_NE(*e, *EntityKeys::build(world).find(entry.key, "test")) << "the indices differ";
  }
  // Attaching again replaces the values through patch (the renderer sees a new change tick).
  const Entity first = *keys.find(data->entries[0].key, "test");
  const std::uint64_t tick = shifted.changed_tick<VertexAO>(first);
  update_world_transforms(shifted);  // advances the tick
  ASSERT_TRUE(attach_bake(shifted, result->file).ok());
  EXPECT_GT(shifted.changed_tick<VertexAO>(first), tick);

  VertexAoData wrong = *data;
  wrong.entries.resize(1);
  wrong.entries[0].ao.push_back(1.0f);
  BakeFile file;
  file.chunks.push_back(write_vertex_ao_chunk(wrong));
  Status s = attach_bake(shifted, file);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::NotFound);
  EXPECT_NE(s.error().message.find("'" + wrong.entries[0].key + "'"), std::string::npos) << s.error().message;
  wrong.entries[0].key = "no/such/mesh";
  file.chunks[0] = write_vertex_ao_chunk(wrong);
  s = attach_bake(shifted, file);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("no entity has the key 'no/such/mesh'"), std::string::npos) << s.error().message;
}

// An entity that bakes data needs a key: an unnamed static mesh is refused by index, with the fix.
TEST(VertexAo, UnkeyedEntitiesAreRefusedNamingTheFix) {
  World world = scene_world("cornell");
  for (Entity e : world.view<Static, Mesh>().sorted_entities()) {
    world.remove<Name>(e);
    break;
  }
  auto result = bake(world, BakeSettings{}, 1);
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.error().message.find("has neither a Name nor an EntityKey"), std::string::npos)
      << result.error().message;
}

TEST(BakeWorld, UnknownBakerAndBudgetAreClearErrors) {
  World world = scene_world("cornell");
  ThreadPool pool(1);
  JobContext jobs(&pool);
  auto unknown = bake_world(world, {"nosuch"}, BakeSettings{}, jobs);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::NotFound);
  EXPECT_NE(unknown.error().message.find("vertex-ao"), std::string::npos) << "lists the known bakers";

  BakeSettings tiny;
  tiny.memory_limit_bytes = 64;
  auto over = bake_world(world, {"vertex-ao"}, tiny, jobs);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, ErrorCode::OutOfBudget);
}

TEST(BakeWorld, CancelledBakeReportsCancelled) {
  World world = scene_world("courtyard");
  ThreadPool pool(2);
  CancelToken cancel;
  cancel.cancel();
  JobContext jobs(&pool, {}, &cancel);
  auto result = bake_world(world, {"vertex-ao"}, BakeSettings{}, jobs);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, ErrorCode::Cancelled);
}

}  // namespace
}  // namespace penumbra
