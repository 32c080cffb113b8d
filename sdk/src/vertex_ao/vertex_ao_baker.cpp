// The vertex-AO bake (see vertex_ao_baker.h).
#include "penumbra/vertex_ao/vertex_ao_baker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <glm/mat3x3.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/entity_key.h"
#include "penumbra/scene/components.h"
#include "penumbra/vertex_ao/vertex_ao.h"
#include "penumbra/vertex_ao/vertex_ao_system.h"

namespace penumbra {

namespace {

// The static meshes to bake, in entity-index order (deterministic whatever the pool order).
std::vector<Entity> static_meshes(World& world) {
  std::vector<Entity> out = world.view<Static, Mesh, WorldTransform>().sorted_entities();
  std::erase_if(out, [&](Entity e) {
    const Mesh& m = world.get<Mesh>(e);
    return !m.data || m.data->positions.empty();
  });
  return out;
}

// The skinned meshes to bake in their bind pose, in entity-index order.
std::vector<Entity> skinned_meshes(World& world) {
  std::vector<Entity> out = world.view<Skin, Mesh>().sorted_entities();
  std::erase_if(out, [&](Entity e) {
    const Mesh& m = world.get<Mesh>(e);
    return world.has<Static>(e) || !m.data || m.data->positions.empty() || m.data->indices.empty();
  });
  return out;
}

// A character in its bind pose, for the AO of one of its skinned meshes: the mesh and the
// character's other meshes whose skins bind the shared joints with the same inverse bind
// matrices (so their vertices as stored lie in one bind space), unskinned. Self-occlusion only:
// the level does not move with the character.
struct BindPoseScene {
  std::unique_ptr<World> world = std::make_unique<World>();
  std::optional<RayScene> rays;
};

bool same_bind_space(const Skin& a, const Skin& b) {
  for (std::size_t i = 0; i < a.joints.size(); ++i)
    for (std::size_t k = 0; k < b.joints.size(); ++k)
      if (a.joints[i] == b.joints[k] && i < a.inverse_bind.size() && k < b.inverse_bind.size()) {
        const glm::mat4 d = a.inverse_bind[i] - b.inverse_bind[k];
        for (int c = 0; c < 4; ++c)
          if (glm::length(d[c]) > 1e-5f * (1.0f + glm::length(a.inverse_bind[i][c]))) return false;
      }
  return true;
}

Result<std::shared_ptr<BindPoseScene>> bind_pose_scene(World& world, Entity mesh) {
  auto scene = std::make_shared<BindPoseScene>();
  const Skin& skin = world.get<Skin>(mesh);
  for (Entity e : character_meshes(world, mesh)) {
    if (e != mesh && !same_bind_space(skin, world.get<Skin>(e))) continue;
    const Entity copy = scene->world->create();
    scene->world->add<Mesh>(copy, Mesh{world.get<Mesh>(e).data});
    scene->world->add<WorldTransform>(copy);
    scene->world->add<Static>(copy);
  }
  auto rays = RayScene::build(*scene->world);
  if (!rays) return rays.error();
  scene->rays.emplace(std::move(*rays));
  return scene;
}

}  // namespace

namespace {

constexpr std::uint64_t kVertexBlock = 4096;  // vertices per work item

// What finish() needs of a group besides its results: the settings the chunk records.
struct VertexAoHeader {
  float max_distance = 0.0f;
  std::uint32_t rays = 0;
};
static_assert(sizeof(VertexAoHeader) == 8, "written as its bytes: no padding");

// A group per static mesh, its vertices the elements (one float of AO each). Vertex v of the
// scene's concatenated vertices (meshes in entity order) draws from Rng::stream(seed, v).
Result<BakeWork> plan_vertex_ao(BakeInputs& in) {
  VertexAoSettings settings = VertexAoSettings::preset(in.settings.preset);
  settings.max_distance = vertex_ao_distance(settings, glm::length(in.rays.bounds_max() - in.rays.bounds_min()));
  std::vector<Entity> entities = static_meshes(in.world);
  const std::size_t static_count = entities.size();
  for (Entity e : skinned_meshes(in.world)) entities.push_back(e);
  auto keys = bake_keys(in, entities, "vertex-AO mesh");
  if (!keys) return keys.error();
  ByteWriter header;
  header.write(VertexAoHeader{settings.max_distance, settings.rays});
  const std::vector<std::byte> header_bytes = header.take();

  struct Group {
    Entity entity;
    std::uint64_t first_vertex;
    std::shared_ptr<BindPoseScene> bind;  // skinned: its character in the bind pose; null: static
  };
  auto groups = std::make_shared<std::vector<Group>>();
  BakeWork work;
  std::uint64_t next = 0;
  for (std::size_t i = 0; i < entities.size(); ++i) {
    const std::size_t n = in.world.get<Mesh>(entities[i]).data->positions.size();
    Group group{entities[i], next, nullptr};
    if (i >= static_count) {
      auto bind = bind_pose_scene(in.world, entities[i]);
      if (!bind) return bind.error();
      group.bind = std::move(*bind);
    }
    work.groups.push_back(BakeGroup{std::move((*keys)[i]), n, kVertexBlock, double(settings.rays), header_bytes});
    groups->push_back(std::move(group));
    next += n;
  }
  work.run = [&in, groups, settings](std::size_t g, std::uint64_t begin, std::uint64_t end,
                                     JobContext& jobs) -> Result<std::vector<std::byte>> {
    // The range's vertices in world space (a skinned mesh's: in its bind space as stored);
    // normals by the inverse transpose.
    const Group& group = (*groups)[g];
    const Entity e = group.entity;
    const MeshData& mesh = *in.world.get<Mesh>(e).data;
    const glm::mat4 m = group.bind ? glm::mat4(1.0f) : in.world.get<WorldTransform>(e).matrix;
    const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(m)));
    const std::size_t count = static_cast<std::size_t>(end - begin);
    PENUMBRA_TRY(in.budget.reserve("vertex AO points", count * (sizeof(SurfacePoint) + sizeof(AoEstimate))));
    std::vector<SurfacePoint> points(count);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t v = static_cast<std::size_t>(begin) + i;
      points[i].position = glm::vec3(m * glm::vec4(mesh.positions[v], 1.0f));
      const glm::vec3 n = v < mesh.normals.size() ? normal_matrix * mesh.normals[v] : glm::vec3(0.0f, 1.0f, 0.0f);
      const float len = glm::length(n);
      points[i].normal = len > 0.0f && std::isfinite(len) ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
    }
    // Trace: one random stream per vertex, results by index (deterministic at any thread count).
    std::vector<AoEstimate> estimates(count);
    AoSettings ao;
    // A character occludes itself at any distance (the level's scale means nothing to it).
    if (!group.bind) ao.max_distance = settings.max_distance;
    ao.rays = settings.rays;
    ao.seed = in.settings.seed;
    ao.first_stream = (*groups)[g].first_vertex + begin;
    const Status traced = ambient_occlusion(group.bind ? *group.bind->rays : in.rays, points, ao, estimates, jobs);
    in.budget.release(count * (sizeof(SurfacePoint) + sizeof(AoEstimate)));
    PENUMBRA_TRY(traced);
    ByteWriter out;
    for (const AoEstimate& a : estimates) out.write(a.value);
    return out.take();
  };
  return work;
}

// One chunk with every mesh's AO, meshes in plan order.
Result<std::vector<BakeChunk>> finish_vertex_ao(std::span<const BakedGroup> groups, JobContext&) {
  std::vector<BakeChunk> chunks;
  if (groups.empty()) return chunks;  // nothing to bake: no chunk
  VertexAoData data;
  for (const BakedGroup& g : groups) {
    const std::string context = "vertex-AO mesh '" + g.group->name + "'";
    ByteReader header(g.group->header, context + " header");
    VertexAoHeader h;
    PENUMBRA_TRY(header.read(h));
    PENUMBRA_TRY(header.finish());
    data.max_distance = h.max_distance;
    data.rays = h.rays;
    VertexAoData::Entry entry;
    entry.key = g.group->name;
    entry.ao.resize(static_cast<std::size_t>(g.group->elements));
    ByteReader results(g.results, context + " results");
    PENUMBRA_TRY(results.read_array(std::span<float>(entry.ao)));
    PENUMBRA_TRY(results.finish());
    data.entries.push_back(std::move(entry));
  }
  chunks.push_back(write_vertex_ao_chunk(data));
  return chunks;
}

}  // namespace

void register_vertex_ao_baker(World& world) {
  Baker b = baker_for(vertex_ao_module());
  b.reads_lights = false;
  b.stages = 1;
  b.hash_inputs = [](World& w, const BakeSettings& s, Hasher& h) {
    const VertexAoSettings v = VertexAoSettings::preset(s.preset);
    h.add(v.max_distance);
    h.add(v.rays);
    h.add(kVertexAoChunkVersion);
    // A skinned mesh's bind scene: its character's meshes and how they are bound.
    for (Entity e : skinned_meshes(w))
      for (Entity other : character_meshes(w, e)) {
        h.add(std::string_view(entity_key(w, other)));
        h.add(w.get<Skin>(other).inverse_bind);
      }
  };
  b.plan = plan_vertex_ao;
  b.finish = finish_vertex_ao;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
