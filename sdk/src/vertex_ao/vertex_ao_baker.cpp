// The vertex-AO bake (see vertex_ao_baker.h).
#include "penumbra/vertex_ao/vertex_ao_baker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/mat3x3.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
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

}  // namespace

namespace {

constexpr std::uint64_t kVertexBlock = 4096;  // vertices per work item

// What finish() needs of a group besides its results: the settings the chunk records.
struct VertexAoHeader {
  float max_distance = 0.0f;
  std::uint32_t rays = 0;
};

// A group per static mesh, its vertices the elements (one float of AO each). Vertex v of the
// scene's concatenated vertices (meshes in entity order) draws from Rng::stream(seed, v).
Result<BakeWork> plan_vertex_ao(BakeInputs& in) {
  VertexAoSettings settings = VertexAoSettings::preset(in.settings.preset);
  settings.max_distance = vertex_ao_distance(settings, glm::length(in.rays.bounds_max() - in.rays.bounds_min()));
  const std::vector<Entity> entities = static_meshes(in.world);
  auto keys = bake_keys(in, entities, "vertex-AO mesh");
  if (!keys) return keys.error();
  ByteWriter header;
  header.write(VertexAoHeader{settings.max_distance, settings.rays});
  const std::vector<std::byte> header_bytes = header.take();

  struct Group {
    Entity entity;
    std::uint64_t first_vertex;
  };
  auto groups = std::make_shared<std::vector<Group>>();
  BakeWork work;
  std::uint64_t next = 0;
  for (std::size_t i = 0; i < entities.size(); ++i) {
    const std::size_t n = in.world.get<Mesh>(entities[i]).data->positions.size();
    work.groups.push_back(BakeGroup{std::move((*keys)[i]), n, kVertexBlock, double(settings.rays), header_bytes});
    groups->push_back({entities[i], next});
    next += n;
  }
  work.run = [&in, groups, settings](std::size_t g, std::uint64_t begin, std::uint64_t end,
                                     JobContext& jobs) -> Result<std::vector<std::byte>> {
    // The range's vertices in world space; normals by the inverse transpose.
    const Entity e = (*groups)[g].entity;
    const MeshData& mesh = *in.world.get<Mesh>(e).data;
    const glm::mat4& m = in.world.get<WorldTransform>(e).matrix;
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
    ao.max_distance = settings.max_distance;
    ao.rays = settings.rays;
    ao.seed = in.settings.seed;
    ao.first_stream = (*groups)[g].first_vertex + begin;
    const Status traced = ambient_occlusion(in.rays, points, ao, estimates, jobs);
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
  b.stages = 1;
  b.hash_inputs = [](World&, const BakeSettings& s, Hasher& h) {
    const VertexAoSettings v = VertexAoSettings::preset(s.preset);
    h.add(v.max_distance);
    h.add(v.rays);
    h.add(kVertexAoChunkVersion);
  };
  b.plan = plan_vertex_ao;
  b.finish = finish_vertex_ao;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
